"""The Signal K output on its links (issue 35): a TCP server whose clients read one
delta a line (what signalk-server's "Signal K over TCP" connection does), UDP
datagrams of one delta each, and what cannot go counted, never raised."""

from __future__ import annotations

import asyncio
import socket

import orjson

from bridge_rig import T0, Ctx, draft, manoeuvre, stw
from edged_signalk.config import SignalKOutputConfig
from edged_signalk.output import SignalKOutput
from waiting import wait_for

TIMEOUT = 5.0


def make(**cfg) -> tuple[SignalKOutput, Ctx]:
    c = Ctx("sk", "signalk")
    out = SignalKOutput(SignalKOutputConfig(type="signalk", **cfg), c.ctx)
    out.check()
    return out, c


async def test_tcp_server_clients_read_one_delta_a_line() -> None:
    out, c = make(transport="tcp", host="127.0.0.1", port=0)
    await out.open()
    try:
        sink = out.sink
        await asyncio.wait_for(sink.listening.wait(), TIMEOUT)  # type: ignore[union-attr]
        readers = [await asyncio.open_connection("127.0.0.1", sink.bound_port) for _ in range(2)]  # type: ignore[union-attr]
        await wait_for(lambda: out.status().get("clients") == 2, TIMEOUT)  # taken in the server's task
        out.write([stw(T0), manoeuvre(T0), draft(T0)])
        for reader, writer in readers:
            lines = [await asyncio.wait_for(reader.readuntil(b"\r\n"), TIMEOUT) for _ in range(5)]
            docs = [orjson.loads(line) for line in lines]
            first = {d["updates"][0]["values"][0]["path"]: d for d in docs}
            assert set(first) == {"navigation.speedThroughWater", "environment.current", "navigation.headingTrue",
                                  "navigation.speedOverGround", "design.draft"}
            assert first["navigation.speedThroughWater"]["updates"][0]["values"][0]["value"] == stw().values["stw"]
            writer.close()
        assert c.health.counters["sent"] == 5 and c.health.info["link"] == "connected"
    finally:
        await out.close()


async def test_udp_datagrams_of_one_delta_each() -> None:
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.setblocking(False)
    loop = asyncio.get_running_loop()
    out, c = make(transport="udp", host="127.0.0.1", port=rx.getsockname()[1])
    await out.open()
    try:
        await wait_for(lambda: c.health.info.get("link") == "connected", TIMEOUT)
        out.write([stw(T0)])
        got = [await asyncio.wait_for(loop.sock_recv(rx, 65536), TIMEOUT) for _ in range(2)]
        paths = {orjson.loads(d)["updates"][0]["values"][0]["path"] for d in got}
        assert paths == {"navigation.speedThroughWater", "environment.current"}
        assert all(d.endswith(b"\r\n") for d in got)
    finally:
        await out.close()
        rx.close()


async def test_a_delta_written_before_the_link_is_open_is_counted_unsent() -> None:
    out, c = make(transport="udp", port=9)
    out.write([stw(T0)])  # not opened: no link yet
    assert c.health.counters["unsent.link_down"] == 2
    await out.close()  # closing what never opened is no error
