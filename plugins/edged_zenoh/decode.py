"""Zenoh payloads -> canonical measurements, for live input and for replay alike.

A raw record of protocol `zenoh` carries the JSON payload as received and, in `meta`,
the key it arrived on and the measurement kind it maps to. Keeping the kind in the
record makes a recording self-describing: a replay without the original configuration
decodes a recorded forecast the same way the live input did.

Payload: a JSON object of the kind's values (DESIGN §2 names), optionally `t` (the
sender's time, kept as `t_src`); `t_src` and `source` of a republished edged
measurement are ignored. Angle fields in [−π, 2π] are mapped onto [0, 2π) (ashore
tools often publish directions in (−π, π]); anything beyond is not a direction and is
rejected, never wrapped (1e300 rad wrapped is a number, not a heading).
"""

from __future__ import annotations

import json
import math
from typing import Any, Mapping

from edged.angles import wrap_2pi
from edged.health import ComponentHealth
from edged.records import KINDS, InvalidMeasurement, Measurement, RawRecord, validate_measurement

__all__ = ["ZenohDecoder", "CURRENT_SUFFIX"]

#: Keys ending so are sea-current forecasts (DESIGN §6 `env/current`).
CURRENT_SUFFIX = "/env/current"
#: Payload members that are about the message, not values of the kind.
_ENVELOPE = ("t", "t_src", "source")
_ANGLES: dict[str, tuple[str, ...]] = {k: tuple(f.name for f in s.fields if f.angle) for k, s in KINDS.items()}
# validate_measurement lets any string through (for `draft.mark`, the one text field):
# a JSON sender can put text anywhere, so every other field must be a JSON number.
_TEXT_UNIT = "name"
_NUMERIC: dict[str, tuple[str, ...]] = {
    k: tuple(f.name for f in s.fields if f.unit != _TEXT_UNIT) for k, s in KINDS.items()
}


class Rejected(Exception):
    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(detail)
        self.reason = reason


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class ZenohDecoder:
    """Decodes `zenoh` raw records; counts every rejection under `rejected.<reason>`."""

    def __init__(self, health: ComponentHealth, kinds_by_key: Mapping[str, str] | None = None) -> None:
        self.health = health
        self.kinds_by_key = dict(kinds_by_key or {})

    def _kind(self, meta: Mapping[str, Any]) -> str:
        kind = meta.get("kind")
        key = str(meta.get("key", ""))
        if kind is None:
            kind = self.kinds_by_key.get(key)
        if kind is None and key.endswith(CURRENT_SUFFIX):
            kind = "current"
        if kind not in KINDS:
            raise Rejected("unknown_key", f"no measurement kind for key {key!r}")
        return kind

    @staticmethod
    def _object(data: bytes) -> dict[str, Any]:
        try:
            obj = json.loads(data)
        except (ValueError, UnicodeDecodeError) as exc:
            raise Rejected("not_json", f"payload is not JSON: {exc}") from None
        if not isinstance(obj, dict):
            raise Rejected("not_object", f"payload is a JSON {type(obj).__name__}, not an object")
        return obj

    def _measurement(self, raw: RawRecord) -> Measurement:
        kind = self._kind(raw.meta or {})
        obj = self._object(raw.data)
        t_src = obj.get("t")
        if t_src is not None and not _number(t_src):
            raise Rejected("bad_time", f"t={t_src!r} is not a finite number of UNIX seconds")
        values = {k: v for k, v in obj.items() if k not in _ENVELOPE}
        for name in _NUMERIC[kind]:
            v = values.get(name)
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))):
                raise Rejected("invalid", f"{kind}.{name} is not a number: {v!r}")
        for name in _ANGLES[kind]:
            v = values.get(name)
            if _number(v):
                if not -math.pi <= v <= 2.0 * math.pi:
                    raise Rejected("invalid", f"{kind}.{name}={v!r} rad is not a direction in [-π, 2π]")
                values[name] = wrap_2pi(float(v))
        try:
            validate_measurement(kind, values)
        except InvalidMeasurement as exc:
            raise Rejected("invalid", str(exc)) from None
        return Measurement(kind, raw.source, raw.t, values, None if t_src is None else float(t_src))

    def decode(self, raw: RawRecord) -> list[Measurement]:
        try:
            return [self._measurement(raw)]
        except Rejected as rej:
            key = (raw.meta or {}).get("key", raw.source)
            self.health.count(f"rejected.{rej.reason}")
            # The message names key and reason only, so a stream of bad payloads logs once.
            self.health.error(f"{key}: rejected ({rej.reason})")
            self.health.info["last_rejected"] = f"{key}: {rej}"
            return []
