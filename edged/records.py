"""The records that flow through edged: measurements, estimates, raw records, health.

This module is the single definition of every measurement kind (DESIGN §2): its name,
its value fields and their SI units. Decoders map onto these kinds; estimators and
outputs read from them. Nothing else in the code base spells a kind's fields.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from typing import Any, Mapping

from .angles import TWO_PI

__all__ = [
    "Field",
    "KindSpec",
    "KINDS",
    "Measurement",
    "Estimate",
    "RawRecord",
    "HealthRecord",
    "Record",
    "InvalidMeasurement",
    "validate_measurement",
    "measurement_to_json",
    "ANGLE_MAX",
]


@dataclass(frozen=True, slots=True)
class Field:
    """One value of a measurement kind.

    `lo`/`hi` are the physically possible bounds: inputs reject what lies outside them
    (DESIGN §8: "reject what cannot be true"), estimators judge the rest.
    """

    name: str
    unit: str
    required: bool = True
    lo: float | None = None
    hi: float | None = None
    angle: bool = False  # true angle in [0, 2π)


@dataclass(frozen=True, slots=True)
class KindSpec:
    name: str
    fields: tuple[Field, ...]
    doc: str

    @property
    def field_names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.fields)


def _k(name: str, doc: str, *fields: Field) -> KindSpec:
    return KindSpec(name, fields, doc)


_ANGLE_BOUND = dict(lo=0.0, hi=TWO_PI)

#: The largest angle in [0, 2π): validate_measurement checks angle fields against it,
#: so that its inclusive comparison excludes 2π itself (`Field.hi` says 2π, the
#: half-open bound).
ANGLE_MAX = math.nextafter(TWO_PI, 0.0)

#: Every measurement kind, DESIGN §2. SI units: m, m/s, m/s², rad, rad/s.
KINDS: dict[str, KindSpec] = {
    k.name: k
    for k in (
        _k(
            "position",
            "Geodetic position (WGS-84).",
            Field("lat", "deg", lo=-90.0, hi=90.0),
            Field("lon", "deg", lo=-180.0, hi=180.0),
            Field("fix_quality", "1", required=False, lo=0, hi=8),  # GGA: 0-8 defined
            Field("hdop", "1", required=False, lo=0.0),
            Field("sats", "1", required=False, lo=0, hi=255),
        ),
        _k(
            "velocity_ground",
            "Speed and course over ground.",
            Field("sog", "m/s", lo=0.0, hi=100.0),
            Field("cog", "rad", required=False, angle=True, **_ANGLE_BOUND),
        ),
        _k("heading", "True heading.", Field("heading", "rad", angle=True, **_ANGLE_BOUND)),
        _k(
            "heading_magnetic",
            "Magnetic heading, used only when no variation is known.",
            Field("heading", "rad", angle=True, **_ANGLE_BOUND),
        ),
        _k("yaw_rate", "Rate of turn, + to starboard.", Field("r", "rad/s", lo=-10.0, hi=10.0)),
        _k(
            "accel_body",
            "Body-frame accelerometer reading with gravity removed (x fwd, y stbd, z down).",
            Field("ax", "m/s^2", lo=-100.0, hi=100.0),
            Field("ay", "m/s^2", lo=-100.0, hi=100.0),
            Field("az", "m/s^2", required=False, lo=-100.0, hi=100.0),
        ),
        _k(
            "attitude",
            "Roll (+ starboard down), pitch (+ bow up), heave (+ down).",
            Field("roll", "rad", lo=-math.pi, hi=math.pi),
            Field("pitch", "rad", lo=-math.pi, hi=math.pi),
            Field("heave", "m", required=False, lo=-100.0, hi=100.0),
        ),
        _k(
            "water_speed",
            "Speed through water from a log.",
            Field("stw_long", "m/s", lo=-100.0, hi=100.0),
            Field("stw_trans", "m/s", required=False, lo=-100.0, hi=100.0),
        ),
        _k(
            "current",
            "Sea current: set (direction it flows toward) and drift (speed).",
            Field("set", "rad", angle=True, **_ANGLE_BOUND),
            Field("drift", "m/s", lo=0.0, hi=20.0),
        ),
        _k(
            "depth",
            "Depth below transducer; offset + transducer to waterline, − to keel.",
            Field("depth", "m", lo=0.0, hi=12000.0),
            Field("offset", "m", required=False, lo=-100.0, hi=100.0),
        ),
        _k(
            "draft",
            "Draft at one mark; status 0 ok, 1 fault, 2 out of water; lost: frames of the "
            "mark lost before this one, as its frame counter says (absent without one).",
            Field("mark", "name"),
            Field("draft", "m", lo=0.0, hi=70.0),
            Field("status", "1", lo=0, hi=255),
            Field("lost", "1", required=False, lo=0, hi=255),
        ),
    )
}


class Measurement:
    """A canonical, stamped reading of one kind from one source (DESIGN §2).

    Plain `__slots__` class rather than a dataclass: millions of these are made per
    voyage and the router's budget is a few microseconds each.
    """

    __slots__ = ("kind", "source", "t", "values", "t_src")

    def __init__(
        self,
        kind: str,
        source: str,
        t: float,
        values: dict[str, Any],
        t_src: float | None = None,
    ) -> None:
        self.kind = kind
        self.source = source
        self.t = t
        self.values = values
        self.t_src = t_src

    @property
    def route_key(self) -> str:
        return self.kind

    def __reduce__(self) -> tuple[Any, ...]:
        # to a process worker: the constructor's arguments (half the bytes and half
        # the time of the default for a __slots__ class)
        return (Measurement, (self.kind, self.source, self.t, self.values, self.t_src))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Measurement):
            return NotImplemented
        return (
            self.kind == other.kind
            and self.source == other.source
            and self.t == other.t
            and self.t_src == other.t_src
            and self.values == other.values
        )

    def __repr__(self) -> str:
        return (
            f"Measurement({self.kind!r}, {self.source!r}, t={self.t!r}, "
            f"values={self.values!r}, t_src={self.t_src!r})"
        )


class Estimate:
    """A fused result of an estimator worker.

    `name` is the estimator instance's configuration table name (`stw`, `stw_paper`):
    estimates are routed like measurements under the key `est/<name>`, so that one
    estimator may consume another's output (the draft worker uses the STW estimate).
    `kind` names its fields in `edged.estimates.ESTIMATE_KINDS` (None: a kind this
    version does not define). The worker host sets `name`, `source` and `kind` from the
    configuration, so a core never chooses the key it is published under.
    """

    __slots__ = ("name", "source", "t", "values", "kind")

    def __init__(
        self, name: str, source: str, t: float, values: dict[str, Any], kind: str | None = None
    ) -> None:
        self.name = name
        self.source = source
        self.t = t
        self.values = values
        self.kind = kind

    @property
    def route_key(self) -> str:
        return "est/" + self.name

    def __reduce__(self) -> tuple[Any, ...]:
        return (Estimate, (self.name, self.source, self.t, self.values, self.kind))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Estimate):
            return NotImplemented
        return (self.name, self.source, self.t, self.values, self.kind) == (
            other.name,
            other.source,
            other.t,
            other.values,
            other.kind,
        )

    def __repr__(self) -> str:
        return (
            f"Estimate({self.name!r}, {self.source!r}, t={self.t!r}, values={self.values!r}, kind={self.kind!r})"
        )


class RawRecord:
    """The exact bytes an input received (a sentence, a CAN frame), for recording.

    `protocol` names the decoder family that can turn it back into measurements
    (e.g. `nmea0183`, `can`): replaying a recording feeds raw records to the same
    decoders the live input used. `meta` holds what the bytes alone do not say
    (a CAN identifier, a TAG block), as JSON-able values.
    """

    __slots__ = ("protocol", "source", "t", "data", "meta")

    route_key = "raw"

    def __init__(
        self,
        protocol: str,
        source: str,
        t: float,
        data: bytes,
        meta: Mapping[str, Any] | None = None,
    ) -> None:
        self.protocol = protocol
        self.source = source
        self.t = t
        self.data = data
        self.meta = meta

    def __reduce__(self) -> tuple[Any, ...]:
        # to the recorder's process: the constructor's arguments (1.0 µs a record
        # pickled instead of 1.75 µs, 29 bytes instead of 45; issue 34)
        return (RawRecord, (self.protocol, self.source, self.t, self.data, self.meta))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RawRecord):
            return NotImplemented
        return (self.protocol, self.source, self.t, self.data, self.meta) == (
            other.protocol,
            other.source,
            other.t,
            other.data,
            other.meta,
        )

    def __repr__(self) -> str:
        return (
            f"RawRecord({self.protocol!r}, {self.source!r}, t={self.t!r}, "
            f"data={self.data!r}, meta={self.meta!r})"
        )


class HealthRecord:
    """A health snapshot (DESIGN §6 `health`), emitted at 1 Hz to the outputs."""

    __slots__ = ("t", "values")

    route_key = "health"
    source = "edged"

    def __init__(self, t: float, values: dict[str, Any]) -> None:
        self.t = t
        self.values = values

    def __reduce__(self) -> tuple[Any, ...]:
        return (HealthRecord, (self.t, self.values))

    def beacon(self) -> HealthRecord:
        """The record without its snapshot: all an estimator worker takes from it is
        its time (data time moves on). Queued whole, the snapshots of a replay of
        many sources filled the workers' queues with gigabytes (issue 32)."""
        return HealthRecord(self.t, {})


Record = Measurement | Estimate | RawRecord | HealthRecord


class InvalidMeasurement(ValueError):
    """A measurement whose values cannot be true (DESIGN §8)."""


_BIG = sys.float_info.max


def _checks(spec: KindSpec) -> tuple[tuple[str, bool, bool, float, float], ...]:
    # Unbounded fields get ±float max, so that one chained comparison rejects NaN
    # (every comparison with NaN is false) and ±inf alike.
    # An angle's bound 2π is exclusive: checked as the float below it.
    return tuple(
        (
            f.name,
            f.required,
            f.unit == "name",
            -_BIG if f.lo is None else f.lo,
            _BIG if f.hi is None else (ANGLE_MAX if f.angle and f.hi == TWO_PI else f.hi),
        )
        for f in spec.fields
    )


#: Per kind: (field, required, is a name, lo, hi), and the set of allowed field names;
#: precomputed because every decoded measurement of every input passes through here.
_CHECKS = {name: (_checks(spec), frozenset(spec.field_names)) for name, spec in KINDS.items()}


def validate_measurement(kind: str, values: Mapping[str, Any]) -> None:
    """Raise InvalidMeasurement naming the field when `values` cannot be true.

    Decoders call this before emitting, so that every input rejects the same things
    (NaN, out of physical range, missing required fields, unknown fields, text where a
    number belongs) the same way.
    """
    entry = _CHECKS.get(kind)
    if entry is None:
        raise InvalidMeasurement(f"unknown kind {kind!r}")
    checks, names = entry
    for name, required, is_name, lo, hi in checks:
        v = values.get(name)
        if v is None:
            if required:
                raise InvalidMeasurement(f"{kind}.{name} missing")
            continue
        tv = type(v)
        if is_name:
            if tv is str and v:
                continue
            raise InvalidMeasurement(f"{kind}.{name} must be a non-empty name: {v!r}")
        if tv is float or tv is int:  # the common case, kept cheap
            if lo <= v <= hi:
                continue
            x = v
        elif isinstance(v, (str, bytes)):
            raise InvalidMeasurement(f"{kind}.{name} not a number: {v!r}")
        else:  # numpy scalars, Decimal, bool ...
            try:
                x = float(v)
            except (TypeError, ValueError):
                raise InvalidMeasurement(f"{kind}.{name} not a number: {v!r}") from None
            if lo <= x <= hi:
                continue
        if x != x or x in (math.inf, -math.inf):
            raise InvalidMeasurement(f"{kind}.{name} is {x}")
        raise InvalidMeasurement(f"{kind}.{name}={x} outside [{lo}, {hi}]")
    if len(values) > len(names) or not names.issuperset(values):
        extra = sorted(set(values) - names)
        raise InvalidMeasurement(f"{kind}: unknown field(s) {extra}")


def measurement_to_json(m: Measurement) -> dict[str, Any]:
    """The JSON form of DESIGN §2: `{"t", "t_src", "source", <values>}`."""
    d: dict[str, Any] = {"t": m.t, "t_src": m.t_src, "source": m.source}
    d.update(m.values)
    return d
