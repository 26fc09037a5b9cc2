"""ZenohInput live: a forecast published from ashore becomes a `current` measurement."""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading

import zenoh

from edged.records import Measurement, RawRecord
from edged_zenoh.input import ZenohInput, ZenohInputConfig
from edged_zenoh.zconfig import safe_defaults, to_zenoh

SAFETY = 30.0


def _wait_matching(pub: zenoh.Publisher) -> None:
    """Block until the publisher has a matching subscriber (the input's)."""
    matched = threading.Event()
    listener = pub.declare_matching_listener(lambda st: matched.set() if st.matching else None)
    if not pub.matching_status.matching:
        assert matched.wait(SAFETY), "the input's subscription never reached the publisher"
    listener.undeclare()


def test_forecast_and_mapped_keys_become_measurements_bad_ones_are_counted(make_ctx, free_port):
    port = free_port()
    c = make_ctx("shore", "v9")
    c.clock.set(1_732_350_100.0)
    received: asyncio.Queue = asyncio.Queue()
    c.ctx.publish = received.put_nowait
    config = ZenohInputConfig.model_validate(
        {
            "type": "zenoh",
            "mode": "peer",
            "listen": [f"tcp/127.0.0.1:{port}"],
            "subscriptions": [{"key": "sensors/echo/*", "kind": "depth", "source": "echo"}],
        }
    )
    inp = ZenohInput(config, c.ctx)

    async def scenario() -> None:
        task = asyncio.create_task(inp.run())
        await asyncio.wait_for(inp.subscribed.wait(), SAFETY)
        ashore = zenoh.open(to_zenoh(safe_defaults(listen=[], connect=[f"tcp/127.0.0.1:{port}"])))
        current = ashore.declare_publisher("vessel/v9/env/current")
        echo = ashore.declare_publisher("sensors/echo/fwd")
        await asyncio.to_thread(_wait_matching, current)
        await asyncio.to_thread(_wait_matching, echo)

        current.put(json.dumps({"t": 1_732_350_000.0, "set": 0.7, "drift": 0.6}))
        current.put(b"not json at all")
        current.put(json.dumps({"t": 1_732_350_000.0, "set": 0.7, "drift": -3.0}))
        echo.put(json.dumps({"depth": 42.0}))
        current.put(json.dumps({"t": 1_732_350_060.0, "set": 0.8, "drift": 0.5}))

        got = []
        while sum(isinstance(r, Measurement) for r in got) < 3:
            got.append(await asyncio.wait_for(received.get(), SAFETY))
        # Samples of different keys run on different channels: order holds within a key.
        raws = [r for r in got if isinstance(r, RawRecord) and r.meta["kind"] == "current"]
        currents = [r for r in got if isinstance(r, Measurement) and r.kind == "current"]
        (depth,) = [r for r in got if isinstance(r, Measurement) and r.kind == "depth"]
        assert [r.meta for r in raws] == [{"key": "vessel/v9/env/current", "kind": "current"}] * 4
        assert raws[1].data == b"not json at all"  # recorded exactly as received
        assert currents == [
            Measurement("current", "shore", 1_732_350_100.0, {"set": 0.7, "drift": 0.6}, 1_732_350_000.0),
            Measurement("current", "shore", 1_732_350_100.0, {"set": 0.8, "drift": 0.5}, 1_732_350_060.0),
        ]
        assert (depth.source, depth.values) == ("echo", {"depth": 42.0})
        assert c.health.counters["rejected.not_json"] == 1
        assert c.health.counters["rejected.invalid"] == 1
        assert c.health.counters["received"] == 5

        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
        assert c.health.state == "connected"  # the shared link states (edged.link)
        assert c.health.snapshot()["ok"] is True
        assert c.health.counters["connects"] == 1
        ashore.close()

    asyncio.run(scenario())


def test_without_a_router_the_input_reports_that_it_is_not_connected(make_ctx, free_port):
    """Client mode, nobody on the endpoint: the shared link states and counters, not ok."""
    port = free_port()
    c = make_ctx("shore", "v9")
    config = ZenohInputConfig.model_validate(
        {"type": "zenoh", "connect": [f"tcp/127.0.0.1:{port}"], "retry_initial": 0.01, "retry_max": 0.02}
    )
    inp = ZenohInput(config, c.ctx)

    async def scenario() -> None:
        task = asyncio.create_task(inp.run())
        try:
            async with asyncio.timeout(SAFETY):
                while c.health.counters.get("connect_failures", 0) < 2:
                    await asyncio.sleep(0.005)
            assert c.health.state in ("connecting", "disconnected")
            assert c.health.snapshot()["ok"] is False
            assert "connects" not in c.health.counters and not inp.subscribed.is_set()
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task

    asyncio.run(scenario())
