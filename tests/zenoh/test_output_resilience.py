"""The output never fails the daemon: no router, a late router, a taken port."""

from __future__ import annotations

import asyncio
import json
import logging
import signal
import socket

import zenoh

from edged.records import Estimate, Measurement
from edged_zenoh.output import ZenohOutput, ZenohOutputConfig
from edged_zenoh.zconfig import safe_defaults, to_zenoh

T0 = 1_732_350_000.0
SAFETY = 30.0


def test_client_mode_keeps_running_without_router_and_publishes_once_it_starts(make_ctx, free_port, router_proc):
    port = free_port()
    c = make_ctx("zenoh", "late")
    cfg = ZenohOutputConfig.model_validate(
        {"type": "zenoh", "mode": "client", "connect": [f"tcp/127.0.0.1:{port}"], "retry_initial": 0.05, "retry_max": 0.2}
    )
    out = ZenohOutput(cfg, c.ctx)

    async def scenario() -> None:
        await out.open()  # returns at once: nothing listens on the port yet
        assert not out.connected.is_set()
        out.write([Estimate("stw", "stw", T0, {"stw": 4.0})])
        assert c.health.counters["unsent.no_session"] == 1
        assert c.health.info["zenoh"] == "connecting"
        while c.health.counters.get("connect_failures", 0) < 2:
            await asyncio.sleep(0)  # let the connector fail twice on its own backoff clock
        assert not out.connected.is_set()

        router = router_proc(port)
        await asyncio.to_thread(router.expect, lambda s: "listening on" in s)
        await asyncio.wait_for(out.connected.wait(), SAFETY)
        assert c.health.info["zenoh"] == "connected"  # the output's link state is info, not its state
        assert c.health.counters["connects"] == 1

        sub_session = zenoh.open(to_zenoh(safe_defaults(mode="client", listen=[], connect=[f"tcp/127.0.0.1:{port}"])))
        got: asyncio.Queue[dict] = asyncio.Queue()
        loop = asyncio.get_running_loop()
        sub = sub_session.declare_subscriber(
            "vessel/late/est/stw",
            lambda s: loop.call_soon_threadsafe(got.put_nowait, json.loads(s.payload.to_bytes())),
        )
        # The value stored while disconnected is there for the asking at once ...
        replies = [r.ok for r in sub_session.get("vessel/late/**", timeout=10) if r.ok is not None]
        assert [json.loads(r.payload.to_bytes())["stw"] for r in replies] == [4.0]
        # ... and new records are published (the get above also proves the router
        # routes our subscription: the output's queryable answered through it).
        out.write([Estimate("stw", "stw", T0 + 1, {"stw": 4.5})])
        assert (await asyncio.wait_for(got.get(), SAFETY))["stw"] == 4.5
        sub.undeclare()
        sub_session.close()
        await out.close()

        router.proc.send_signal(signal.SIGTERM)
        router.expect(lambda s: s == "edged router stopped")
        assert router.proc.wait(SAFETY) == 0

    asyncio.run(scenario())


def test_peer_without_anyone_reachable_keeps_accepting_records(make_ctx, free_port):
    """A peer whose connect endpoint is dead opens anyway and keeps the latest values."""
    port, dead = free_port(), free_port()
    c = make_ctx("zenoh", "alone")
    cfg = ZenohOutputConfig.model_validate(
        {"type": "zenoh", "listen": [f"tcp/127.0.0.1:{port}"], "connect": [f"tcp/127.0.0.1:{dead}"]}
    )
    out = ZenohOutput(cfg, c.ctx)

    async def scenario() -> None:
        await out.open()
        await asyncio.wait_for(out.connected.wait(), SAFETY)
        out.write([Measurement("heading", "gyro", T0 + i * 0.1, {"heading": 0.1 * i}) for i in range(20)])
        assert c.health.counters["published"] == 20
        assert "errors" not in c.health.counters
        assert len(out.latest) == 1
        await out.close()

    asyncio.run(scenario())


def test_taken_port_falls_back_to_a_free_one_and_says_so(make_ctx, free_port, caplog):
    port = free_port()
    holder = socket.socket()
    holder.bind(("127.0.0.1", port))
    holder.listen()
    c = make_ctx("zenoh", "fb")
    out = ZenohOutput(ZenohOutputConfig.model_validate({"type": "zenoh", "listen": [f"tcp/127.0.0.1:{port}"]}), c.ctx)

    async def scenario() -> None:
        with caplog.at_level(logging.WARNING):
            await out.open()
            await asyncio.wait_for(out.connected.wait(), SAFETY)
        (listen,) = c.health.info["listen"]
        assert listen.startswith("tcp/127.0.0.1:") and listen != f"tcp/127.0.0.1:{port}"
        assert c.health.counters["listen_fallback"] == 1
        assert any(f"tcp/127.0.0.1:{port} is taken" in r.getMessage() and listen in r.getMessage() for r in caplog.records)
        # Somebody can reach the daemon on the port it reported.
        s = zenoh.open(to_zenoh(safe_defaults(listen=[], connect=[listen])))
        out.write([Estimate("stw", "stw", T0, {"stw": 3.0})])
        replies = [r.ok for r in s.get("vessel/fb/est/stw", timeout=10) if r.ok is not None]
        assert len(replies) == 1
        s.close()
        await out.close()

    try:
        asyncio.run(scenario())
    finally:
        holder.close()


def test_no_fallback_when_disabled_retries_instead(make_ctx, free_port):
    port = free_port()
    holder = socket.socket()
    holder.bind(("127.0.0.1", port))
    holder.listen()
    c = make_ctx("zenoh", "nofb")
    cfg = ZenohOutputConfig.model_validate(
        {"type": "zenoh", "listen": [f"tcp/127.0.0.1:{port}"], "listen_fallback": False, "retry_initial": 0.01}
    )
    out = ZenohOutput(cfg, c.ctx)

    async def scenario() -> None:
        await out.open()
        while c.health.counters.get("connect_failures", 0) < 2:
            await asyncio.sleep(0)  # yield to the connector; it retries on its own clock
        assert not out.connected.is_set()
        assert "Address already in use" in (c.health.last_error or "")
        holder.close()  # the port frees up: the next retry opens
        await asyncio.wait_for(out.connected.wait(), SAFETY)
        assert c.health.info["listen"] == [f"tcp/127.0.0.1:{port}"]
        await out.close()

    try:
        asyncio.run(scenario())
    finally:
        holder.close()
