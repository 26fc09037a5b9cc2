"""Fixtures of the MCAP recorder tests: a recorder on a manual clock, sample records."""

from __future__ import annotations

import asyncio
import random
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import pytest

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


@pytest.fixture
def make_rig() -> Callable[..., Rig]:
    """A recorder built from config keys, on a manual clock at T0."""

    def make(*, free_bytes: Callable[[Path], int] | None = None, opener: Any = None, **cfg: Any) -> Rig:
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

    return make


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


@pytest.fixture
def records() -> list[Any]:
    return sample_records()


@pytest.fixture
def sample() -> Callable[..., list[Any]]:
    return sample_records


#: JSON types and what Python value each admits (for the structural schema checks).
_JSON_TYPES: dict[str, Callable[[Any], bool]] = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "number": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
}


def check_schema(schema: Any, where: str = "$") -> None:
    """Structural check that `schema` is a well-formed JSON Schema (the subset used)."""
    assert isinstance(schema, dict), where
    t = schema.get("type")
    if t is not None:
        types = t if isinstance(t, list) else [t]
        assert types and all(x in _JSON_TYPES for x in types), f"{where}: type {t!r}"
    props = schema.get("properties", {})
    assert isinstance(props, dict), where
    for k, sub in props.items():
        check_schema(sub, f"{where}.{k}")
    req = schema.get("required", [])
    assert isinstance(req, list) and len(set(req)) == len(req), where
    assert set(req) <= set(props), f"{where}: required {set(req) - set(props)} not in properties"
    if "items" in schema:
        check_schema(schema["items"], f"{where}[]")
    for bound in ("minimum", "maximum"):
        if bound in schema:
            assert _JSON_TYPES["number"](schema[bound]), where
    if "additionalProperties" in schema:
        assert isinstance(schema["additionalProperties"], bool), where


def conforms(value: Any, schema: dict[str, Any], where: str = "$") -> None:
    """Assert `value` satisfies `schema` (types, required, bounds, closed objects)."""
    t = schema.get("type")
    if t is not None:
        types = t if isinstance(t, list) else [t]
        assert any(_JSON_TYPES[x](value) for x in types), f"{where}: {value!r} is not {t}"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        assert value >= schema.get("minimum", value), where
        assert value <= schema.get("maximum", value), where
    if "enum" in schema:
        assert value in schema["enum"], where
    if isinstance(value, dict):
        props = schema.get("properties", {})
        for k in schema.get("required", []):
            assert k in value, f"{where}: missing {k}"
        if schema.get("additionalProperties") is False:
            assert set(value) <= set(props), f"{where}: extra {set(value) - set(props)}"
        for k, v in value.items():
            if k in props:
                conforms(v, props[k], f"{where}.{k}")
    if isinstance(value, list) and "items" in schema:
        assert len(value) >= schema.get("minItems", 0), where
        assert len(value) <= schema.get("maxItems", len(value)), where
        for i, v in enumerate(value):
            conforms(v, schema["items"], f"{where}[{i}]")


@pytest.fixture
def schema_checks() -> tuple[Callable[..., None], Callable[..., None]]:
    return check_schema, conforms
