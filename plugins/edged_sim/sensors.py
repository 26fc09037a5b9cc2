"""Sensor models: what an instrument reports, given the truth at its sampling instants.

A sensor is data (`SensorSpec`): a measurement model, a rate, its errors (white noise,
bias, resolution, lost samples, outages, position jumps; and faults over windows of
time: an offset added to a field, a field forced to a value such as a status code or
an impossible reading, spells of lost samples, a sensor frozen on its last value) and the formats it sends.
The measurement models are a table keyed by name; each turns truth samples into the
values the formats encode, in SI units. Every sensor draws from its own random stream
(seeded by the run's seed and the sensor's name), so adding a sensor to a scenario
does not change the noise of the others.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from edged.angles import wrap_2pi
from edged.geo import LocalPlane


#: Fields that are true angles on [0, 2π).
ANGLES = frozenset({"heading", "cog", "set", "yaw"})


@dataclass(frozen=True)
class SensorSpec:
    name: str  #: unique in a scenario, e.g. "gnss1.position"
    model: str  #: key of MODELS
    rate_hz: float
    outputs: tuple[str, ...]  #: encoder keys, e.g. ("nmea:GGA", "n2k:129025")
    noise: Mapping[str, float] = field(default_factory=dict)  #: 1-σ per field (SI)
    bias: Mapping[str, float] = field(default_factory=dict)
    quantum: Mapping[str, float] = field(default_factory=dict)  #: the instrument's resolution
    dropout: float = 0.0  #: probability that a sample is lost
    outages: tuple[tuple[float, float], ...] = ()  #: (start, end) s without output
    #: Position glitches: (start s, end s, north m, east m) added to the position.
    jumps: tuple[tuple[float, float, float, float], ...] = ()
    offset_ms: int = 0  #: phase of the sampling grid, so instruments do not all fire together
    talker: str = "GP"  #: NMEA 0183 talker
    address: int = 0  #: NMEA 2000 source address
    mark: str = ""  #: draft sensors: which mark
    #: Offsets over windows: (start s, end s, field, value added), e.g. a sensor jumping by 1 m.
    offsets: tuple[tuple[float, float, str, float], ...] = ()
    #: A field forced to a value over windows: (start s, end s, field, value), e.g. a
    #: status code that is not ok, or a reading outside the physical range.
    forced: tuple[tuple[float, float, str, float], ...] = ()
    #: Spells of lost samples: (start s, end s, probability that a sample is lost). They
    #: draw from their own stream (`spell_rng`), so the sensor's noise is that of the
    #: same sensor without them.
    dropout_spells: tuple[tuple[float, float, float], ...] = ()
    #: Windows (start s, end s) over which the sensor goes on sending, on its own grid,
    #: the values of its last sample before the window (a frozen heading, a hung
    #: receiver): every field repeats, only the frames' sequence numbers move on.
    frozen: tuple[tuple[float, float], ...] = ()

    @property
    def period_ms(self) -> int:
        return int(round(1000.0 / self.rate_hz))

    def sample_times_ms(self, start_ms: int, end_ms: int) -> np.ndarray:
        """Sampling instants in [start_ms, end_ms), on the sensor's own grid."""
        p = self.period_ms
        first = -(-(start_ms - self.offset_ms) // p)
        last = -(-(end_ms - self.offset_ms) // p)
        return self.offset_ms + np.arange(first, last, dtype=np.int64) * p

    def rng(self, seed: int) -> np.random.Generator:
        return np.random.default_rng([seed, zlib.crc32(self.name.encode())])

    def spell_rng(self, seed: int) -> np.random.Generator:
        """The stream the dropout spells draw from (apart from `rng`)."""
        return np.random.default_rng([seed, zlib.crc32(self.name.encode()), 1])

    def windows(self) -> list[dict]:
        """The windows of time with faults (outages, offsets, forced values, dropout
        spells), for meta.json, in time order."""
        out = [{"sensor": self.name, "kind": "outage", "start_s": a, "end_s": b} for a, b in self.outages]
        out += [{"sensor": self.name, "kind": "offset", "start_s": a, "end_s": b, "field": f, "value": v}
                for a, b, f, v in self.offsets]
        out += [{"sensor": self.name, "kind": "forced", "start_s": a, "end_s": b, "field": f, "value": v}
                for a, b, f, v in self.forced]
        out += [{"sensor": self.name, "kind": "dropout", "start_s": a, "end_s": b, "probability": p}
                for a, b, p in self.dropout_spells]
        out += [{"sensor": self.name, "kind": "frozen", "start_s": a, "end_s": b} for a, b in self.frozen]
        return sorted(out, key=lambda w: (w["start_s"], w["end_s"]))

    def without_errors(self) -> "SensorSpec":
        """The same instrument, perfect: for tests that compare a log with the truth."""
        from dataclasses import replace

        return replace(self, noise={}, bias={}, quantum={}, dropout=0.0, outages=(), jumps=(), offsets=(), forced=(),
                       dropout_spells=(), frozen=())


Truth = Mapping[str, np.ndarray]
Model = Callable[[Truth, SensorSpec, np.random.Generator, LocalPlane], dict[str, np.ndarray]]


def perturb(values: dict[str, np.ndarray], spec: SensorSpec, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Bias, white noise and resolution on the fields the spec names (in field order,
    so the random draws are reproducible)."""
    for name in values:
        x = values[name]
        if name in spec.bias:
            x = x + spec.bias[name]
        if name in spec.noise:
            x = x + spec.noise[name] * rng.standard_normal(x.shape)
        if name in spec.quantum:
            q = spec.quantum[name]
            x = np.round(x / q) * q
        values[name] = wrap_2pi(x) if name in ANGLES else x
    return values


def _position(tr: Truth, spec: SensorSpec, rng: np.random.Generator, frame: LocalPlane) -> dict[str, np.ndarray]:
    n = np.array(tr["x"], dtype=float)
    e = np.array(tr["y"], dtype=float)
    sigma = spec.noise.get("position", 0.0)
    if sigma:
        n = n + sigma * rng.standard_normal(n.shape)
        e = e + sigma * rng.standard_normal(e.shape)
    for start, end, dn, de in spec.jumps:
        inside = (tr["t_rel"] >= start) & (tr["t_rel"] < end)
        n, e = n + dn * inside, e + de * inside
    lat, lon = frame.to_geodetic_array(n, e)
    one = np.ones_like(n)
    return {"lat": lat, "lon": lon, "fix_quality": one, "sats": 12 * one, "hdop": 0.9 * one}


def _velocity_ground(tr: Truth, spec: SensorSpec, rng: np.random.Generator, frame: LocalPlane) -> dict[str, np.ndarray]:
    # Noise on the velocity vector, not on speed and course: COG is noisy at low speed.
    vn = tr["sog"] * np.cos(tr["cog"])
    ve = tr["sog"] * np.sin(tr["cog"])
    sigma = spec.noise.get("velocity", 0.0)
    if sigma:
        vn = vn + sigma * rng.standard_normal(vn.shape)
        ve = ve + sigma * rng.standard_normal(ve.shape)
    return {"sog": np.hypot(vn, ve), "cog": wrap_2pi(np.arctan2(ve, vn))}


def _fields(*names: str, **renamed: str) -> Model:
    """A model that reports truth fields as they are (then `perturb` adds the errors)."""

    def model(tr: Truth, spec: SensorSpec, rng: np.random.Generator, frame: LocalPlane) -> dict[str, np.ndarray]:
        out = {n: np.array(tr[n], dtype=float) for n in names}
        out.update({k: np.array(tr[v], dtype=float) for k, v in renamed.items()})
        return perturb(out, spec, rng)

    return model


def _current(tr: Truth, spec: SensorSpec, rng: np.random.Generator, frame: LocalPlane) -> dict[str, np.ndarray]:
    # Forecast error as a vector (σ per component), so a weak current's drift stays ≥ 0.
    vn = tr["current_drift"] * np.cos(tr["current_set"])
    ve = tr["current_drift"] * np.sin(tr["current_set"])
    sigma = spec.noise.get("velocity", 0.0)
    if sigma:
        vn = vn + sigma * rng.standard_normal(vn.shape)
        ve = ve + sigma * rng.standard_normal(ve.shape)
    return {"set": wrap_2pi(np.arctan2(ve, vn)), "drift": np.hypot(vn, ve)}


def _time(tr: Truth, spec: SensorSpec, rng: np.random.Generator, frame: LocalPlane) -> dict[str, np.ndarray]:
    return {}


def _water_speed(tr: Truth, spec: SensorSpec, rng: np.random.Generator, frame: LocalPlane) -> dict[str, np.ndarray]:
    out = perturb({"stw_long": np.array(tr["stw_long"]), "stw_trans": np.array(tr["stw_trans"])}, spec, rng)
    out["ground_long"], out["ground_trans"] = np.array(tr["u"]), np.array(tr["v"])
    return out


def _depth(tr: Truth, spec: SensorSpec, rng: np.random.Generator, frame: LocalPlane) -> dict[str, np.ndarray]:
    out = perturb({"depth": np.array(tr["depth_below_transducer"])}, spec, rng)
    out["offset"] = np.full_like(out["depth"], spec.bias.get("offset", 0.0))
    return out


def _draft(tr: Truth, spec: SensorSpec, rng: np.random.Generator, frame: LocalPlane) -> dict[str, np.ndarray]:
    out = perturb({"draft": np.array(tr[f"draft_{spec.mark}"])}, spec, rng)
    out["status"] = np.zeros_like(out["draft"])
    return out


#: Measurement models by name.
MODELS: dict[str, Model] = {
    "position": _position,
    "velocity_ground": _velocity_ground,
    "time": _time,
    "heading": _fields("heading"),
    "yaw_rate": _fields("r"),
    "imu_accel": _fields("ax", "ay", "az"),
    "imu_rate": _fields("r", "roll_rate", "pitch_rate"),
    "attitude": _fields("roll", "pitch", "heave", yaw="heading"),
    "water_speed": _water_speed,
    "current": _current,
    "depth": _depth,
    "draft": _draft,
}


def measure(spec: SensorSpec, truth: Truth, rng: np.random.Generator, frame: LocalPlane) -> dict[str, np.ndarray]:
    """The values a sensor reports at the instants `truth` was sampled at, with its
    windowed offsets and forced values (which draw nothing from `rng`)."""
    values = MODELS[spec.model](truth, spec, rng, frame)
    if spec.offsets or spec.forced:
        t = np.asarray(truth["t_rel"])
        for start, end, name, value in spec.offsets:
            inside = (t >= start) & (t < end)
            if inside.any():
                x = _field(values, spec, name) + value * inside
                values[name] = wrap_2pi(x) if name in ANGLES else x
        for start, end, name, value in spec.forced:
            inside = (t >= start) & (t < end)
            if inside.any():
                values[name] = np.where(inside, value, _field(values, spec, name))
    return values


def freeze(spec: SensorSpec, t_rel: np.ndarray, values: dict[str, np.ndarray],
           last: dict[str, float]) -> dict[str, np.ndarray]:
    """The values with every sample inside a `frozen` window replaced by the sensor's
    last sample before the window. `last` holds the values of the last sample of the
    previous chunk (updated here), so a window that began in an earlier chunk goes on
    repeating the value it froze on. Draws nothing from any random stream."""
    n = t_rel.size
    if n == 0:
        return values
    out = {k: np.array(v, dtype=float, copy=True) for k, v in values.items()}
    for start, end in spec.frozen:
        inside = (t_rel >= start) & (t_rel < end)
        if not inside.any():
            continue
        before = np.flatnonzero(t_rel < start)
        for k, x in out.items():
            if before.size:
                ref = x[before[-1]]
            elif k in last:
                ref = last[k]
            else:  # frozen from the first sample of the run: its first value
                ref = x[np.flatnonzero(inside)[0]]
            x[inside] = ref
    last.update({k: float(x[-1]) for k, x in out.items()})
    return out


def _field(values: dict[str, np.ndarray], spec: SensorSpec, name: str) -> np.ndarray:
    if name not in values:
        raise KeyError(f"sensor {spec.name}: model {spec.model!r} has no field {name!r} (it has {sorted(values)})")
    return np.asarray(values[name], dtype=float)


def kept(spec: SensorSpec, t_rel: np.ndarray, rng: np.random.Generator,
         spell_rng: np.random.Generator | None = None) -> np.ndarray:
    """Mask of samples that are not lost (random dropouts, outages and, drawn from
    `spell_rng`, the dropout spells)."""
    keep = np.ones(t_rel.shape, dtype=bool)
    if spec.dropout > 0.0:
        keep &= rng.uniform(size=t_rel.shape) >= spec.dropout
    for start, end in spec.outages:
        keep &= ~((t_rel >= start) & (t_rel < end))
    if spec.dropout_spells:
        u = (spell_rng if spell_rng is not None else rng).uniform(size=t_rel.shape)
        for start, end, p in spec.dropout_spells:
            keep &= ~((t_rel >= start) & (t_rel < end) & (u < p))
    return keep
