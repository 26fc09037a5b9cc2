"""The server itself: where it listens, a port that is taken, closing, who watches,
the measurements' rate limit, and records it cannot serve."""

from __future__ import annotations

import asyncio
import json
import socket
from pathlib import Path

import pytest
import websockets
from bridge_rig import T0, Ctx, stw

from edged.records import Estimate, Measurement
from edged_foxglove.config import FoxgloveOutputConfig
from edged_foxglove.output import FoxgloveOutput


TIMEOUT = 5.0


def _listening_addresses(port: int) -> set[str]:
    """Local addresses (hex, as the kernel writes them) of TCP sockets listening on `port`."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        p = Path(table)
        if not p.exists():
            continue
        for line in p.read_text().splitlines()[1:]:
            fields = line.split()
            addr, hexport = fields[1].split(":")
            if int(hexport, 16) == port and fields[3] == "0A":  # 0A: LISTEN
                found.add(addr)
    return found


async def test_listens_on_this_machine_only_by_default(fox):
    assert FoxgloveOutputConfig(type="foxglove").host == "127.0.0.1"
    assert FoxgloveOutputConfig(type="foxglove").port == 8765
    out, c = await fox()  # the default host, a port of the kernel's choosing
    assert out.port and out.port != 0
    assert c.health.info["url"] == f"ws://127.0.0.1:{out.port}"
    if not Path("/proc/net/tcp").exists():
        pytest.skip("no /proc/net/tcp to read the listening address from")
    assert _listening_addresses(out.port) == {"0100007F"}  # 127.0.0.1, nothing else


async def test_a_port_in_use_is_a_clear_error_counted_in_health(fox):
    held = socket.socket()
    held.bind(("127.0.0.1", 0))
    held.listen()
    port = held.getsockname()[1]
    c = Ctx("fox", "foxglove")
    out = FoxgloveOutput(FoxgloveOutputConfig(type="foxglove", port=port), c.ctx)
    try:
        with pytest.raises(OSError, match=rf"cannot listen on 127\.0\.0\.1:{port}: .*in use"):
            await out.open()
        assert c.health.counters["errors.bind"] == 1
        assert "in use" in (c.health.last_error or "")
        assert c.health.info["url"] is None
        out.write([stw()])  # never raises: counted
        assert c.health.counters["dropped.not_open"] == 1
    finally:
        held.close()
    await out.open()  # the runtime's next attempt, once the port is free
    try:
        assert out.port == port
    finally:
        await out.close()


async def test_close_stops_the_server(fox):
    out, c = await fox()
    port = out.port
    await out.close()
    assert out.port is None and c.health.info["url"] is None
    with pytest.raises(OSError):
        await asyncio.wait_for(websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"]), TIMEOUT)
    out.write([stw()])
    assert c.health.counters["dropped.not_open"] == 1


async def test_clients_and_subscriptions_in_status(fox, client):
    out, _ = await fox()
    out.write([stw(T0)])
    a, b = await client(out), await client(out)
    await a.subscribe(out, "/est/stw")
    await b.subscribe(out, "/est/stw")
    assert out.status() | {"port": 0} == {"channels": 1, "port": 0, "clients": 2, "subscriptions": 2, "subscribes": 2}
    await b.ws.close()
    await asyncio.wait_for(out.clients(1), TIMEOUT)
    assert out.status()["subscriptions"] == 1


async def test_measurements_are_thinned_per_channel_estimates_are_not(fox, client):
    out, c = await fox()  # meas_default_hz = 10
    fc = await client(out)

    def mark(t: float, name: str) -> Measurement:
        return Measurement("draft", f"can0.{name}", t, {"mark": name, "draft": 8.0, "status": 0})

    out.write([mark(T0 - 10, "fore_port"), mark(T0 - 10, "aft_port"), stw(T0 - 10)])
    await fc.subscribe(out, "/meas/draft/can0.fore_port", "/meas/draft/can0.aft_port", "/est/stw")
    batch = []
    for i in range(100):  # one second of 100 Hz marks, and estimates at 100 Hz too
        t = T0 + i * 0.01
        batch += [mark(t, "fore_port"), mark(t, "aft_port"), stw(t)]
    out.write(batch + [stw(T0 + 5)])
    got = await fc.messages_until("/est/stw", (int(T0) + 5) * 10**9)  # up to the sentinel
    per_topic = {t: sum(1 for m in got if m[0] == t) for t in {m[0] for m in got}}
    assert per_topic == {"/meas/draft/can0.fore_port": 10, "/meas/draft/can0.aft_port": 10, "/est/stw": 101}
    assert c.health.counters["rate_limited"] == 180
    fore = [ns for t, ns, _ in got if t == "/meas/draft/can0.fore_port"]
    assert [round((ns - fore[0]) / 1e8) for ns in fore] == list(range(10))  # 10 Hz of data time


async def test_a_kind_can_be_switched_off_or_given_its_own_rate(fox, client):
    out, c = await fox(meas_max_hz={"heading": 0.0, "velocity_ground": 1.0})
    fc = await client(out)
    out.write([Measurement("velocity_ground", "gnss1", T0 - 10, {"sog": 6.0}), stw(T0 - 10)])
    await fc.subscribe(out, "/meas/velocity_ground/gnss1", "/est/stw")
    recs = [Measurement("velocity_ground", "gnss1", T0 + i * 0.1, {"sog": 6.0}) for i in range(30)]
    recs += [Measurement("heading", "gyro", T0, {"heading": 1.0}), stw(T0 + 5)]
    out.write(recs)
    got = await fc.messages_until("/est/stw")
    assert sum(1 for m in got if m[0] == "/meas/velocity_ground/gnss1") == 3  # 1 Hz over 3 s
    assert "/meas/heading/gyro" not in fc.channels and out.status()["channels"] == 2
    assert c.health.counters["rate_limited"] == 27


async def test_records_it_cannot_serve_are_counted_never_raised(fox, client):
    out, c = await fox()
    fc = await client(out)
    out.write([stw(T0)])
    await fc.subscribe(out, "/est/stw")
    bad = [
        stw(float("nan")),  # no log time
        stw(-1.0),
        object(),  # not a record
        stw(T0 + 1, stw=object()),  # not JSON
        Measurement("position", "gnss1", T0, None),  # type: ignore[arg-type]
        stw(T0 + 2, current=float("inf")),  # served, the infinity as null
    ]
    out.write(bad)
    topic, _, payload = await fc.message()
    assert topic == "/est/stw" and json.loads(payload)["current"] is None and json.loads(payload)["t"] == T0 + 2
    counters = c.health.counters
    assert counters["rejected.bad_time"] == 2
    assert counters["rejected.unknown_record"] == 1
    assert counters["rejected.unencodable"] == 1
    assert counters["rejected.malformed"] == 1
    assert counters["nonfinite_as_null"] == 1
    assert counters["sent"] == 1


async def test_an_unknown_kind_of_record_is_rejected_even_unwatched(fox):
    out, c = await fox()
    out.write([Estimate("stw", "stw", T0, {"stw": 1.0}, "stw"), object()])
    assert c.health.counters["unwatched"] == 1 and c.health.counters["rejected.unknown_record"] == 1
    assert "sent" not in c.health.counters
