"""Received JSON payloads back to records: the inverse of `edged.jsonpayload.record_json`
for the estimates and health snapshots a vessel publishes (DESIGN §6).

`edged fleet --record` gives an MCAP recorder the records a vessel's own recorder got,
so that a shore file has the channels and payloads of one made on board. The
reconstruction is exact for what edged publishes: the record made here is encoded by
`record_json` into the same JSON object (same members, same order, same values) and by
`edged.jsonpayload.dumps` into the same bytes. What the JSON does not carry is set as
the worker host sets it: an estimate's `source` is its name.

- An estimate of key `est/<name>`: `Estimate(name, name, t, <the members but t and
  kind>, kind)`; `kind` a string or null (absent: null; `record_json` then adds the
  common members an edged vessel always sends, `stale`, `age`, `converging`).
- A health snapshot: `HealthRecord(t, <every member>)`.

Anything else is refused with a reason (`NotARecord.reason`, counted by the caller as
`rejected.<reason>`): a payload over `MAX_PAYLOAD` bytes (`too_large`), not JSON or with
NaN/Infinity, nested deeper than orjson reads (`not_json`), not an object
(`not_object`), a `t` that is not a number of UNIX seconds in [1980, 2100) (`bad_time`,
DESIGN §3: a time that cannot be true), a `kind` that is not a string (`bad_kind`).
"""

from __future__ import annotations

import math
import re
from typing import Any

import orjson

from edged.records import Estimate, HealthRecord
from edged.timecheck import EARLIEST, LATEST

__all__ = [
    "MAX_PAYLOAD",
    "MAX_NAME",
    "NotARecord",
    "valid_name",
    "load_object",
    "data_time",
    "estimate_from_json",
    "health_from_json",
    "record_from_json",
]

#: The largest payload taken (bytes): a health snapshot of a vessel with the most
#: plugins DESIGN §1 allows is a few tens of KiB.
MAX_PAYLOAD = 4 << 20
#: The longest name taken (a vessel id, an estimate name): it becomes a file name.
MAX_NAME = 128
#: DESIGN's names (the vessel id, an estimator instance): letters, digits, `_ - .`, not
#: beginning with `.` or `-` (so never `.`, `..`, nor an option). ASCII only, matched
#: whole (`fullmatch`: a trailing newline is not a name).
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]*")


class NotARecord(ValueError):
    """A payload that is no estimate or health snapshot; `reason` is the counter's."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(detail)
        self.reason = reason


def valid_name(name: str) -> bool:
    """True when `name` is a vessel id or estimate name edged accepts (DESIGN §4, §6):
    safe as one path component and one key chunk."""
    return isinstance(name, str) and 0 < len(name) <= MAX_NAME and _NAME.fullmatch(name) is not None


def load_object(payload: bytes) -> dict[str, Any]:
    """The JSON object of `payload` (orjson: NaN and Infinity are not JSON, nesting is
    bounded, invalid UTF-8 is refused); NotARecord otherwise."""
    if len(payload) > MAX_PAYLOAD:
        raise NotARecord("too_large", f"payload of {len(payload)} bytes (at most {MAX_PAYLOAD})")
    try:
        obj = orjson.loads(payload)
    except (orjson.JSONDecodeError, RecursionError) as exc:
        raise NotARecord("not_json", f"payload is not JSON: {exc}") from None
    if not isinstance(obj, dict):
        raise NotARecord("not_object", f"payload is a JSON {type(obj).__name__}, not an object")
    return obj


def data_time(obj: dict[str, Any]) -> float:
    """The object's `t`: UNIX seconds, finite, in [1980-01-01, 2100-01-01)."""
    t = obj.get("t")
    if isinstance(t, bool) or not isinstance(t, (int, float)):
        raise NotARecord("bad_time", f"t={t!r} is not a number of UNIX seconds")
    tf = float(t)
    if not (math.isfinite(tf) and EARLIEST <= tf < LATEST):
        raise NotARecord("bad_time", f"t={t!r} is not a time between 1980 and 2100")
    return tf


def estimate_from_json(name: str, obj: dict[str, Any]) -> Estimate:
    """The Estimate published as `obj` under `est/<name>`."""
    t = data_time(obj)
    kind = obj.get("kind")
    if kind is not None and not isinstance(kind, str):
        raise NotARecord("bad_kind", f"kind={kind!r} is not a name")
    values = {k: v for k, v in obj.items() if k != "t" and k != "kind"}
    return Estimate(name, name, t, values, kind)


def health_from_json(obj: dict[str, Any]) -> HealthRecord:
    """The HealthRecord published as `obj` under `health`."""
    return HealthRecord(data_time(obj), dict(obj))


def record_from_json(rest: str, payload: bytes) -> Estimate | HealthRecord:
    """The record a sample of `vessel/<id>/<rest>` carries: `rest` is `health` or
    `est/<name>`; NotARecord (`bad_key`) for any other key."""
    if rest == "health":
        return health_from_json(load_object(payload))
    if rest.startswith("est/"):
        name = rest[4:]
        if not valid_name(name):
            raise NotARecord("bad_key", f"est/{name[:80]!r}: not an estimate name")
        return estimate_from_json(name, load_object(payload))
    raise NotARecord("bad_key", f"{rest[:80]!r}: not an estimate or health key")
