"""Records to channel messages and back: topics and payloads of DESIGN §7.

In the core because two outputs speak them: the MCAP recorder (`edged_mcap`) writes
them and the live Foxglove server (`edged_foxglove`) serves the same bytes, so a
layout made for one shows the other; neither plugin may import the other.

`encode(record)` gives the messages one record becomes (a position is also a
`foxglove.LocationFix`); `raw_from_message` turns a recorded raw message back into the
exact RawRecord that went in, which is what replay feeds to the inputs' decoders.

Time: a message's log time is the record's `t` in nanoseconds, but the payload keeps
the float `t` itself, so replay reproduces it bit for bit (ns rounding would not).
"""

from __future__ import annotations

import math
from typing import Any, Callable, Iterable

from . import jsonpayload
from .estimates import ESTIMATE_KINDS
from .jsonpayload import record_json
from .records import KINDS, Estimate, HealthRecord, Measurement, RawRecord

from .schemas import LOCATION_FIX

__all__ = [
    "Out",
    "encode",
    "to_ns",
    "MAX_T",
    "dumps",
    "raw_from_message",
    "RAW_PREFIX",
    "NotRaw",
]

RAW_PREFIX = "/raw/"


#: One message to write: (topic, schema name, JSON payload). A plain tuple, not a
#: NamedTuple: building a NamedTuple costs about half a microsecond, and a replay makes
#: two or three messages per sentence.
Out = tuple[str, str, dict[str, Any]]


class NotRaw(ValueError):
    """A message that cannot be turned back into a RawRecord (named reason)."""


#: Log times are uint64 nanoseconds: data time must lie in [1970, 2554) (the recorder
#: and the live Foxglove output reject a record outside it, counted `bad_time`).
MAX_T = (2**64 - 1) / 1e9


def to_ns(t: float) -> int:
    """Seconds to MCAP nanoseconds (uint64: times before 1970 clamp to 0).

    Whole seconds and the fraction are converted apart: `t * 1e9` alone would round
    to 256 ns steps at today's epoch times.
    """
    sec = math.floor(t)
    ns = sec * 1_000_000_000 + round((t - sec) * 1e9)
    return ns if ns > 0 else 0


#: One encoder of JSON payloads for every output (NaN and infinity as null, counted).
dumps = jsonpayload.dumps


# -- raw records --------------------------------------------------------------------
def _raw_nmea(r: RawRecord) -> dict[str, Any]:
    try:
        return {"t": r.t, "line": r.data.decode("utf-8"), "meta": r.meta}
    except UnicodeDecodeError:  # garbage on the wire is recorded too, byte for byte
        return {"t": r.t, "data_hex": r.data.hex(), "meta": r.meta}


def _raw_can(r: RawRecord) -> dict[str, Any]:
    # The CAN input puts the identifier and its width in meta {"id", "ext"}; they are
    # also top-level fields so that tools can filter frames without knowing edged.
    meta = r.meta if isinstance(r.meta, dict) else {}
    return {"t": r.t, "id": meta.get("id"), "ext": meta.get("ext"), "data": r.data.hex(), "meta": r.meta}


def _raw_other(r: RawRecord) -> dict[str, Any]:
    return {"t": r.t, "data": r.data.hex(), "meta": r.meta}


#: protocol -> (schema name, payload maker); other protocols are recorded as hex.
_RAW: dict[str, tuple[str, Callable[[RawRecord], dict[str, Any]]]] = {
    "nmea0183": ("edged.raw.nmea0183", _raw_nmea),
    "can": ("edged.raw.can", _raw_can),
}
_RAW_DEFAULT = ("edged.raw", _raw_other)


def _encode_raw(r: RawRecord) -> Iterable[Out]:
    schema, make = _RAW.get(r.protocol, _RAW_DEFAULT)
    return ((f"/raw/{r.protocol}/{r.source}", schema, make(r)),)


def _data_of(payload: dict[str, Any]) -> bytes:
    line = payload.get("line")
    if isinstance(line, str):
        return line.encode("utf-8")
    for key in ("data_hex", "data"):
        h = payload.get(key)
        if isinstance(h, str):
            return bytes.fromhex(h)
    raise NotRaw("no line or data")


def raw_from_message(topic: str, payload: Any) -> RawRecord:
    """The RawRecord a `/raw/<protocol>/<source>` message was made of (NotRaw if none)."""
    parts = topic.split("/", 3)
    if len(parts) != 4 or parts[1] != "raw" or not parts[2] or not parts[3]:
        raise NotRaw("topic")
    if not isinstance(payload, dict):
        raise NotRaw("payload")
    t = payload.get("t")
    if not isinstance(t, (int, float)) or isinstance(t, bool):
        raise NotRaw("time")
    try:
        data = _data_of(payload)
    except ValueError as exc:  # bad hex is a ValueError as well
        raise NotRaw(f"data: {exc}") from None
    meta = payload.get("meta")
    return RawRecord(parts[2], parts[3], float(t), data, meta if isinstance(meta, dict) else None)


# -- measurements, estimates, health -----------------------------------------------
def _location_fix(m: Measurement) -> Out:
    ns = to_ns(m.t)
    v = m.values
    return (
        f"/location/{m.source}",
        LOCATION_FIX,
        {
            "timestamp": {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000},
            "frame_id": m.source,
            "latitude": v["lat"],
            "longitude": v["lon"],
            "altitude": 0.0,
            # Covariance unknown (type 0): an HDOP is not a covariance without a UERE.
            "position_covariance": [0.0] * 9,
            "position_covariance_type": 0,
        },
    )


def _encode_measurement(m: Measurement) -> Iterable[Out]:
    schema = f"edged.meas.{m.kind}" if m.kind in KINDS else "edged.meas"
    out = (f"/meas/{m.kind}/{m.source}", schema, record_json(m))
    if m.kind == "position" and "lat" in m.values and "lon" in m.values:
        return (out, _location_fix(m))
    return (out,)


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _estimate_fix(e: Estimate) -> Out | None:
    """An estimate's position (`lat`, `lon`) as a LocationFix on `/location/est/<name>`,
    for the map, with its 1-σ north and east (`std.x`, `std.y`) as the diagonal of the
    ENU covariance; None without a position, or when the estimate is stale."""
    v = e.values
    lat, lon = v.get("lat"), v.get("lon")
    if not (_finite(lat) and _finite(lon)) or v.get("stale"):
        return None
    std = v.get("std")
    sn, se = (std.get("x"), std.get("y")) if isinstance(std, dict) else (None, None)
    known = _finite(sn) and _finite(se)
    ns = to_ns(e.t)
    return (
        f"/location/est/{e.name}",
        LOCATION_FIX,
        {
            "timestamp": {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000},
            "frame_id": e.name,
            "latitude": lat,
            "longitude": lon,
            "altitude": 0.0,
            "position_covariance": [se * se, 0.0, 0.0, 0.0, sn * sn, 0.0, 0.0, 0.0, 0.0] if known else [0.0] * 9,
            "position_covariance_type": 2 if known else 0,  # 2: diagonal known
        },
    )


def _encode_estimate(e: Estimate) -> Iterable[Out]:
    # The core's JSON of the estimate (the same bytes Zenoh publishes); the channel's
    # schema is its kind's, or the open one for a kind this version does not define.
    schema = f"edged.est.{e.kind}" if e.kind in ESTIMATE_KINDS else "edged.est"
    out = (f"/est/{e.name}", schema, record_json(e))
    fix = _estimate_fix(e)
    return (out,) if fix is None else (out, fix)


def _encode_health(h: HealthRecord) -> Iterable[Out]:
    return (("/health", "edged.health", record_json(h)),)


_ENCODERS: dict[type, Callable[[Any], Iterable[Out]]] = {
    RawRecord: _encode_raw,
    Measurement: _encode_measurement,
    Estimate: _encode_estimate,
    HealthRecord: _encode_health,
}


def encode(record: Any) -> Iterable[Out]:
    """The messages `record` is recorded as; KeyError for a type edged does not know."""
    return _ENCODERS[type(record)](record)
