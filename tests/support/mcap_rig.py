"""A recorder on a manual clock that writes real MCAP files, and sample records: what
the MCAP plugin's tests (`tests/mcap`) and the analysis plugin's (`tests/analysis`,
score and plot read recordings) write their recordings with."""

from __future__ import annotations

import asyncio
import random
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged.records import Estimate, HealthRecord, Measurement, RawRecord
from edged_mcap.recorder import McapRecorder

T0 = 1_732_350_000.0


@dataclass
class Rig:
    rec: McapRecorder
    clock: ManualClock
    health: ComponentHealth

    def open(self) -> None:
        asyncio.run(self.rec.open())

    def close(self) -> None:
        asyncio.run(self.rec.close())


def make_rig(*, free_bytes: Callable[[Path], int] | None = None, opener: Any = None, **cfg: Any) -> Rig:
    """A recorder built from config keys, on a manual clock at T0."""
    clock = ManualClock(T0)
    health = ComponentHealth("rec", "output", "mcap", clock)
    ctx = PluginContext(
        "rec", clock, health, lambda r: None, vessel_id="ship1", options={"config_text": "[edged]\nvessel_id = 'ship1'\n"}
    )
    kw: dict[str, Any] = {}
    if free_bytes is not None:
        kw["free_bytes"] = free_bytes
    if opener is not None:
        kw["opener"] = opener
    config = McapRecorder.Config.model_validate({"type": "mcap", **cfg})
    return Rig(McapRecorder(config, ctx, **kw), clock, health)


def write_recording(path: Path, records: Sequence[Any], **cfg: Any) -> Path:
    """`records` recorded into the file `path` (opened, written in one batch, closed)."""
    rig = make_rig(path=str(path), **cfg)
    rig.open()
    rig.rec.write(list(records))
    rig.close()
    return path


def sample_records(seconds: int = 3, seed: int = 1) -> list[Any]:
    """A small reference-like mix: raw NMEA and CAN, measurements, estimates, health."""
    rnd = random.Random(seed)
    out: list[Any] = []
    for s in range(seconds):
        for i in range(10):
            t = T0 + s + i * 0.1
            out.append(RawRecord("nmea0183", "gnss1", t, b"$GPGGA,082000.00,6005.000,N,02330.000,E,1,08,0.9,5.0,M,,M,,*00\r\n", {"tag": f"c:{t}"}))
            out.append(Measurement("position", "gnss1", t, {"lat": 60.08 + rnd.random() * 1e-4, "lon": 23.5, "fix_quality": 1}))
            out.append(Measurement("velocity_ground", "gnss1", t, {"sog": 5.0 + rnd.random(), "cog": 1.0}))
            for mark in range(6):
                out.append(RawRecord("can", "can0", t + mark * 1e-3, bytes([rnd.randrange(256) for _ in range(4)]), {"id": 0x310 + mark, "ext": False}))
                out.append(Measurement("draft", "can0.DraftMark", t + mark * 1e-3, {"mark": f"m{mark}", "draft": 8.0 + rnd.random(), "status": 0}))
            out.append(Estimate("stw", "stw", t, {"stw": 5.1, "stw_std": 0.1, "sog": 5.2, "dvl_stw": None, "mode": "full"}))
            out.append(Estimate("manoeuvre", "manoeuvre", t, {"lat": 60.08, "lon": 23.5, "u": 5.0, "v": 0.1, "r": 0.01, "std": {"u": 0.1}}))
            out.append(Estimate("draft", "draft", t, {"marks": {"fore": {"mean": 8.0}, "aft": {"mean": 8.5}}, "mean_draft": 8.25, "trim": 0.5, "list": 0.0}))
        out.append(HealthRecord(T0 + s, {"t": T0 + s, "outputs": {"rec": {"state": "recording"}}}))
    return out


def voyage_with_a_log_gap(path: Path) -> Path:
    """A 5-s sample voyage recorded by edged, with a Doppler log that is silent for
    30 s (a gap for `inspect`, a line of `plot`'s speed panel)."""
    rig = make_rig(path=str(path))
    rig.open()
    recs = sample_records(seconds=5)
    recs += [Measurement("water_speed", "log1", 1_732_350_000.0 + s, {"stw_long": 5.0}) for s in (0, 1, 31, 32)]
    rig.rec.write(recs)
    rig.close()
    return path


def foreign_mcap(path: Path, messages: Sequence[tuple[str, bytes]], step_ns: int = 1) -> Path:
    """An MCAP file with JSON channels written by the mcap library (not by edged):
    message i logged `step_ns` × i after 2024-11-23T08:20Z."""
    from mcap.writer import Writer

    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema("x", "jsonschema", b"{}")
        ids: dict[str, int] = {}
        for i, (topic, data) in enumerate(messages):
            if topic not in ids:
                ids[topic] = w.register_channel(topic, "json", sid)
            w.add_message(ids[topic], 1_732_350_000_000_000_000 + i * step_ns, data, 0)
        w.finish()
    return path
