"""The key space and JSON payloads of DESIGN §6, in one place.

`KeySpace` spells every key under the vessel's prefix; `payload_of` turns a record into
the JSON object published for it, through a table keyed by record type (no per-
estimator code: an estimate named `foo` becomes `est/foo` with `{"t", **values}`).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from typing import Any, Callable

import orjson

from edged.records import Estimate, HealthRecord, Measurement, measurement_to_json

__all__ = ["KeySpace", "PAYLOADS", "payload_of", "encode", "valid_chunk"]

_BAD_CHUNK = re.compile(r"[*$?#/\s]")


def valid_chunk(name: str) -> bool:
    """A name usable as one key chunk: not empty, no wildcard nor separator."""
    return bool(name) and _BAD_CHUNK.search(name) is None


@dataclass(frozen=True)
class KeySpace:
    """Keys under `prefix` (default `vessel/<vessel_id>`)."""

    prefix: str

    @property
    def everything(self) -> str:
        return self.prefix + "/**"

    @property
    def health(self) -> str:
        return self.prefix + "/health"

    @property
    def alive(self) -> str:
        return self.prefix + "/alive"

    @property
    def env_current(self) -> str:
        return self.prefix + "/env/current"

    def est(self, name: str) -> str:
        return f"{self.prefix}/est/{name}"

    def meas(self, kind: str, source: str) -> str:
        return f"{self.prefix}/meas/{kind}/{source}"


def _estimate_json(e: Estimate) -> dict[str, Any]:
    out: dict[str, Any] = {"t": e.t}
    out.update(e.values)
    return out


def _health_json(h: HealthRecord) -> dict[str, Any]:
    return h.values


#: Record type -> its JSON object. Raw records have no entry: they are not published.
PAYLOADS: dict[type, Callable[[Any], dict[str, Any]]] = {
    Measurement: measurement_to_json,
    Estimate: _estimate_json,
    HealthRecord: _health_json,
}


def payload_of(rec: Any) -> dict[str, Any]:
    return PAYLOADS[type(rec)](rec)


def _finite(obj: Any) -> Any:
    """NaN and infinities as null: a filter that lost track says so without breaking JSON."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj


def _default(obj: Any) -> Any:
    """numpy scalars and arrays (estimators' natural currency) as plain JSON values."""
    for attr in ("tolist", "item"):
        fn = getattr(obj, attr, None)
        if fn is not None:
            return fn()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


# Built once: json.dumps with options makes a new encoder per call (a third of the cost).
# The standard library is the authority on what is JSON, and the fallback for the little
# orjson refuses (integers beyond 64 bits, strings with lone surrogates).
_STRICT = json.JSONEncoder(separators=(",", ":"), allow_nan=False, default=_default)
_LAX = json.JSONEncoder(default=_default)
_ORJSON_OPTIONS = orjson.OPT_NON_STR_KEYS


def _has_nonfinite(obj: Any) -> bool:
    """True when a NaN or infinity is somewhere in `obj` (payloads are small and flat:
    one loop over the values, a call only for nested containers)."""
    if isinstance(obj, dict):
        values: Any = obj.values()
    elif isinstance(obj, (list, tuple)):
        values = obj
    elif isinstance(obj, float):
        return not math.isfinite(obj)
    else:
        tolist = getattr(obj, "tolist", None)  # numpy values: as they will be written
        return callable(tolist) and _has_nonfinite(tolist())
    for v in values:
        c = v.__class__
        if c is float:
            if v - v != 0.0:  # NaN - NaN and inf - inf are NaN, which equals nothing
                return True
        elif c is not str and c is not int and c is not bool and v is not None and _has_nonfinite(v):
            return True
    return False


def _encode_strict(obj: dict[str, Any]) -> tuple[bytes, bool]:
    try:
        return _STRICT.encode(obj).encode(), False
    except ValueError:
        return _STRICT.encode(_finite(json.loads(_LAX.encode(obj)))).encode(), True


def encode(obj: dict[str, Any]) -> tuple[bytes, bool]:
    """Compact JSON bytes of `obj`, and whether non-finite numbers had to become null.

    orjson costs a tenth of `json.dumps` (every published record passes here) and
    already writes NaN and infinity as null: only a payload with a null in it is
    searched for them. Raises TypeError when a value has no JSON form.

    The plain call comes first: passing `default` and `option` costs orjson as much
    as the encoding of a small payload, and they change nothing for the payloads that
    need neither (string keys, plain Python values), which are nearly all.
    """
    try:
        data = orjson.dumps(obj)
    except TypeError:  # non-string keys, numpy values ...: the full call decides
        try:
            data = orjson.dumps(obj, default=_default, option=_ORJSON_OPTIONS)
        except TypeError:  # orjson.JSONEncodeError: let the standard library decide
            return _encode_strict(obj)
    # `find` rather than `in`: half the cost on bytes, and this runs for every record.
    return data, data.find(b"null") >= 0 and _has_nonfinite(obj)
