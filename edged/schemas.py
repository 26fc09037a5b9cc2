"""JSON schemas of the channels recorded to MCAP and served live to Foxglove (DESIGN §7).

Every channel carries a JSON Schema so that Foxglove and other MCAP tools can show
field names and types without knowing edged. Measurement schemas are derived from
`edged.records.KINDS`, the single definition of the kinds, so a new field there is
recorded with the right schema without touching this module.
"""

from __future__ import annotations

import json
from functools import cache
from typing import Any

from .estimates import COMMON_FIELDS, ESTIMATE_KINDS, EstField, EstimateKind
from .records import KINDS, Field, KindSpec

__all__ = [
    "SCHEMA_ENCODING",
    "MESSAGE_ENCODING",
    "LOCATION_FIX",
    "schema_bytes",
    "schema_dict",
]

SCHEMA_ENCODING = "jsonschema"
MESSAGE_ENCODING = "json"
_DRAFT = "https://json-schema.org/draft/2020-12/schema"

#: Schema name of Foxglove's map message; Foxglove recognises it by this exact name.
LOCATION_FIX = "foxglove.LocationFix"

_NUMBER_OR_NULL = {"type": ["number", "null"]}
_TIME = {"type": "number", "description": "data time, UTC seconds (UNIX epoch)"}
_META = {
    "type": ["object", "null"],
    "description": "what the bytes alone do not say (TAG block, CAN identifier), as the input gave it",
}


def _obj(title: str, description: str, properties: dict[str, Any], required: list[str], *, extra: bool) -> dict[str, Any]:
    return {
        "$schema": _DRAFT,
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
        "required": required,
        "additionalProperties": extra,
    }


def _field_schema(f: Field) -> dict[str, Any]:
    # A field whose unit is a name (the draft mark) is a label, every other one a number.
    if f.unit == "name":
        return {"type": "string", "description": "name"}
    s: dict[str, Any] = {"type": "number" if f.required else ["number", "null"], "description": f.unit}
    if f.lo is not None:
        s["minimum"] = f.lo
    if f.hi is not None:
        s["maximum"] = f.hi
    return s


def _measurement(spec: KindSpec) -> dict[str, Any]:
    props: dict[str, Any] = {
        "t": _TIME,
        "t_src": {**_NUMBER_OR_NULL, "description": "time the sensor itself reported, UTC seconds"},
        "source": {"type": "string"},
    }
    props.update({f.name: _field_schema(f) for f in spec.fields})
    required = ["t", "source", *(f.name for f in spec.fields if f.required)]
    return _obj(f"edged.meas.{spec.name}", spec.doc, props, required, extra=False)


def _raw_nmea() -> dict[str, Any]:
    props = {
        "t": _TIME,
        "line": {"type": "string", "description": "the sentence exactly as received (UTF-8)"},
        "data_hex": {"type": "string", "description": "the bytes in hex, only when they are not UTF-8"},
        "meta": _META,
    }
    return _obj("edged.raw.nmea0183", "One NMEA 0183 sentence as received.", props, ["t"], extra=False)


def _raw_can() -> dict[str, Any]:
    props = {
        "t": _TIME,
        "id": {"type": ["integer", "null"], "description": "CAN identifier"},
        "ext": {"type": ["boolean", "null"], "description": "29-bit identifier"},
        "data": {"type": "string", "description": "frame payload in hex"},
        "meta": _META,
    }
    return _obj("edged.raw.can", "One CAN frame as received.", props, ["t", "data"], extra=False)


def _raw_other() -> dict[str, Any]:
    props = {"t": _TIME, "data": {"type": "string", "description": "bytes in hex"}, "meta": _META}
    return _obj("edged.raw", "Raw bytes of a protocol without its own schema.", props, ["t", "data"], extra=False)


def _estimate() -> dict[str, Any]:
    # An estimate of a kind this version does not define: only `t` is certain.
    return _obj("edged.est", "A fused estimate of a kind this version does not define.", {"t": _TIME}, ["t"], extra=True)


def _est_field(f: EstField) -> dict[str, Any]:
    types: Any = [f.type, "null"] if f.nullable else f.type
    # No bounds for angles: a heading is in [0, 2π), a drift angle in (−π, π].
    return {"type": types, "description": f"{f.doc} [{f.unit}]"}


def _estimate_kind(kind: EstimateKind) -> dict[str, Any]:
    # From the one definition of the kind (edged.estimates). Estimators may add fields
    # (DESIGN §6: more may be added, none renamed), so extra properties are allowed.
    props = {f.name: _est_field(f) for f in COMMON_FIELDS + kind.fields}
    if kind.mark_fields:
        mark = {"type": "object", "properties": {f.name: _est_field(f) for f in kind.mark_fields}}
        props["marks"] = {**props["marks"], "properties": {m: mark for m in kind.marks}}
    required = [f.name for f in COMMON_FIELDS]
    return _obj(f"edged.est.{kind.name}", kind.doc, props, required, extra=True)


def _health() -> dict[str, Any]:
    props = {"t": _TIME}
    for role in ("inputs", "workers", "estimators", "outputs", "routers"):
        props[role] = {"type": "object", "description": f"{role}: per component state and counters"}
    return _obj("edged.health", "Health snapshot of every component (1 Hz).", props, ["t"], extra=True)


def _location_fix() -> dict[str, Any]:
    # Field names and meaning follow Foxglove's published LocationFix message.
    time = {
        "type": "object",
        "properties": {
            "sec": {"type": "integer", "minimum": 0},
            "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999},
        },
        "required": ["sec", "nsec"],
    }
    props = {
        "timestamp": {**time, "description": "time of the fix"},
        "frame_id": {"type": "string", "description": "frame of the sensor"},
        "latitude": {"type": "number", "description": "degrees"},
        "longitude": {"type": "number", "description": "degrees"},
        "altitude": {"type": "number", "description": "metres"},
        "position_covariance": {
            "type": "array",
            "items": {"type": "number"},
            "minItems": 9,
            "maxItems": 9,
            "description": "ENU covariance (m^2), row-major",
        },
        "position_covariance_type": {"type": "integer", "enum": [0, 1, 2, 3], "description": "0 unknown"},
    }
    return _obj(LOCATION_FIX, "A GNSS fix, for Foxglove's map panel.", props, list(props), extra=True)


def _all() -> dict[str, dict[str, Any]]:
    out = {s["title"]: s for s in (_raw_nmea(), _raw_can(), _raw_other(), _estimate(), _health(), _location_fix())}
    out.update({f"edged.meas.{k}": _measurement(spec) for k, spec in KINDS.items()})
    out.update({f"edged.est.{k}": _estimate_kind(kind) for k, kind in ESTIMATE_KINDS.items()})
    out["edged.meas"] = _obj("edged.meas", "A measurement of a kind unknown to this version.", {"t": _TIME}, ["t"], extra=True)
    return out


@cache
def _table() -> dict[str, dict[str, Any]]:
    return _all()


def schema_dict(name: str) -> dict[str, Any]:
    """The schema called `name` (KeyError when there is none)."""
    return _table()[name]


@cache
def schema_bytes(name: str) -> bytes:
    """The schema as it goes into the file (compact UTF-8 JSON)."""
    return json.dumps(schema_dict(name), separators=(",", ":")).encode()
