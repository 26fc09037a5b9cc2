"""One estimate, one JSON: what Zenoh publishes is byte for byte what MCAP records."""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path

import numpy as np
import zenoh
from mcap.reader import make_reader

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged.records import Estimate
from edged_mcap.recorder import McapRecorder
from edged_zenoh.output import ZenohOutput, ZenohOutputConfig
from edged_zenoh.zconfig import safe_defaults, to_zenoh

T0 = 1_732_350_000.0
SAFETY = 30.0


def _estimates() -> list[Estimate]:
    values = {
        "t": 99.0,  # a value named t: the record's time wins on both outputs
        "stw": np.float64(5.125),
        "stw_std": math.nan,  # no JSON form: null on both
        "mode": "vector",
        "dvl_std": {"bias": 0.01, "scale": np.float32(0.5)},
        "stale": False,
        "age": 0.25,
    }
    return [Estimate("stw_paper", "stw_paper", T0 + 1 / 3, values, kind="stw")]


def _recorded(tmp_path: Path) -> bytes:
    clock = ManualClock(T0)
    ctx = PluginContext("rec", clock, ComponentHealth("rec", "output", "mcap", clock), lambda r: None)
    path = tmp_path / "one.mcap"
    rec = McapRecorder(McapRecorder.Config.model_validate({"type": "mcap", "path": str(path)}), ctx)
    asyncio.run(rec.open())
    rec.write(_estimates())
    asyncio.run(rec.close())
    with open(path, "rb") as f:
        ((_, channel, message),) = [m for m in make_reader(f).iter_messages() if m[1].topic.startswith("/est/")]
    assert channel.topic == "/est/stw_paper"
    return message.data


def _published(make_ctx, port: int) -> bytes:
    c = make_ctx("zenoh", "v1")
    cfg = ZenohOutputConfig.model_validate({"type": "zenoh", "listen": [f"tcp/127.0.0.1:{port}"]})
    out = ZenohOutput(cfg, c.ctx)

    async def scenario() -> bytes:
        await out.open()
        await asyncio.wait_for(out.connected.wait(), SAFETY)
        s = zenoh.open(to_zenoh(safe_defaults(listen=[], connect=[f"tcp/127.0.0.1:{port}"])))
        loop = asyncio.get_running_loop()
        got: asyncio.Queue[bytes] = asyncio.Queue()
        sub = s.declare_subscriber(
            "vessel/v1/est/**", lambda sample: loop.call_soon_threadsafe(got.put_nowait, sample.payload.to_bytes())
        )
        try:
            for _ in range(int(SAFETY / 0.05)):  # until the subscription has reached the output
                out.write(_estimates())
                try:
                    return await asyncio.wait_for(got.get(), 0.05)
                except asyncio.TimeoutError:
                    continue
            raise AssertionError("no sample reached the subscriber")
        finally:
            sub.undeclare()
            s.close()
            await out.close()

    return asyncio.run(scenario())


def test_the_same_estimate_is_the_same_json_on_zenoh_and_in_mcap(make_ctx, free_port, tmp_path):
    recorded = _recorded(tmp_path)
    published = _published(make_ctx, free_port())
    assert published == recorded
    obj = json.loads(published)
    assert obj["t"] == T0 + 1 / 3 and obj["kind"] == "stw" and obj["stw_std"] is None
    assert obj["dvl_std"] == {"bias": 0.01, "scale": 0.5} and obj["age"] == 0.25
