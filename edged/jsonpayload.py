"""Records' JSON payloads as bytes: the one encoder every output uses.

NaN and infinity are not JSON: readers (Foxglove, pandas, jq, a browser) reject a
message that holds them, so they are written as null and the caller is told, to count
it. A filter that lost track says so in health without breaking a subscriber.

orjson encodes in a tenth of the standard library's time (every record of a replay is
encoded at least once per output) and already writes non-finite numbers as null; only
a payload with a null in it is searched for one. The plain call comes first: passing
`default` and `option` costs orjson as much as encoding a small payload, and they change
nothing for nearly all payloads (string keys, plain Python values). The standard library
is the authority on what is JSON, and the fallback for what orjson refuses (integers
beyond 64 bits, strings with lone surrogates).
"""

from __future__ import annotations

import json
import math
from typing import Any

import orjson

from .estimates import estimate_to_json
from .records import Estimate, HealthRecord, Measurement, measurement_to_json

__all__ = ["dumps", "record_json", "health_to_json"]


def _plain(o: Any) -> Any:
    """numpy scalars and arrays (estimators' natural currency) and sets as JSON values."""
    for attr in ("tolist", "item"):
        fn = getattr(o, attr, None)
        if callable(fn):
            return fn()
    if isinstance(o, (set, frozenset, tuple)):
        return list(o)
    raise TypeError(f"{type(o).__name__} is not JSON serialisable")


def _finite(o: Any) -> Any:
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    return o


def _has_nonfinite(o: Any) -> bool:
    """True when a NaN or infinity is somewhere in `o` (payloads are small and flat:
    one loop over the values, a call only for nested containers)."""
    if isinstance(o, dict):
        values: Any = o.values()
    elif isinstance(o, (list, tuple)):
        values = o
    elif isinstance(o, float):
        return not math.isfinite(o)
    else:
        tolist = getattr(o, "tolist", None)  # numpy values: as they will be written
        return callable(tolist) and _has_nonfinite(tolist())
    for v in values:
        c = v.__class__
        if c is float:
            if v - v != 0.0:  # NaN - NaN and inf - inf are NaN, which equals nothing
                return True
        elif c is not str and c is not int and c is not bool and v is not None and _has_nonfinite(v):
            return True
    return False


#: Built once: `json.dumps` with options builds a new encoder per call.
_STRICT = json.JSONEncoder(separators=(",", ":"), allow_nan=False, default=_plain).encode
_LAX = json.JSONEncoder(default=_plain).encode
_ORJSON_OPTIONS = orjson.OPT_NON_STR_KEYS


def _dumps_strict(payload: Any) -> tuple[bytes, bool]:
    try:
        return _STRICT(payload).encode(), False
    except ValueError:
        return _STRICT(_finite(json.loads(_LAX(payload)))).encode(), True


def dumps(payload: Any) -> tuple[bytes, bool]:
    """Compact JSON bytes of `payload`, and whether non-finite numbers became null.

    Raises TypeError (or ValueError) when a value has no JSON form.
    """
    try:
        data = orjson.dumps(payload)
    except TypeError:  # non-string keys, numpy values ...: the full call decides
        try:
            data = orjson.dumps(payload, default=_plain, option=_ORJSON_OPTIONS)
        except TypeError:  # orjson.JSONEncodeError: let the standard library decide
            return _dumps_strict(payload)
    # `find` rather than `in`: half the cost on bytes, and this runs for every message.
    if data.find(b"null") < 0:
        return data, False
    # A measurement's JSON has a null of its own (`t_src`): when every null written is
    # one of the object's own None values, none is a non-finite number (two C-level
    # counts instead of walking the payload in Python for every message).
    if payload.__class__ is dict:
        try:
            if data.count(b"null") == list(payload.values()).count(None):
                return data, False
        except ValueError:  # a value whose == is not a truth (a numpy array): walk it
            pass
    return data, _has_nonfinite(payload)


def health_to_json(h: HealthRecord) -> dict[str, Any]:
    """A health snapshot's JSON object; the record's `t` wins."""
    d: dict[str, Any] = {"t": h.t}
    d.update(h.values)
    d["t"] = h.t
    return d


#: Record type -> its JSON object: the one mapping every output uses (Zenoh payloads
#: and MCAP messages of the same record are the same JSON). Raw records have none:
#: each recorder spells its raw channels itself, and nothing publishes them.
_JSON_OF = {
    Measurement: measurement_to_json,
    Estimate: estimate_to_json,
    HealthRecord: health_to_json,
}


def record_json(rec: Any) -> dict[str, Any]:
    """The JSON object of a measurement, estimate or health record (KeyError otherwise)."""
    return _JSON_OF[type(rec)](rec)
