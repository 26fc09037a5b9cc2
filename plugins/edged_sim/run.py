"""A simulation run: integrate, sample the sensors, encode, damage — chunk by chunk.

Both the file writer and the live emitter consume `Simulation.chunks()`; neither knows
how the records were made, and both get the same records for the same seed.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Iterator

import numpy as np

from edged.geo import LocalPlane
from edged.units import KNOT

from .dynamics import Integrator
from .emit import Batch, output
from .faults import damage_frames, damage_nmea, garbage_line
from .scenario import Scenario
from .sensors import freeze, kept, measure
from .truth import TruthModel, columns


@dataclass
class Chunk:
    start_s: float
    end_s: float
    truth: dict[str, np.ndarray]  #: truth.csv rows of this chunk
    nmea: Batch
    can: Batch


class Simulation:
    """One run of a scenario with one seed."""

    def __init__(self, scenario: Scenario, seed: int = 0, duration: float | None = None, ideal: bool = False,
                 overrides: dict[str, str] | None = None) -> None:
        self.scenario = scenario.without_errors() if ideal else scenario
        self.overrides = dict(overrides or {})  #: command-line options that changed the scenario, as given
        self.seed = seed
        self.duration = scenario.duration_s if duration is None else float(duration)
        sc = self.scenario
        self.helm = sc.helm.make(sc.ship)
        self.integrator = Integrator(sc.ship, self.helm, sc.dt, sc.heading_deg, sc.helm.speed_kn * KNOT)
        self.frame = LocalPlane(*sc.origin)
        env_rng = np.random.default_rng([seed, 0])
        # The wave yaw draws from a stream of its own: scenarios without it keep their bytes.
        yaw = None if sc.wave_yaw is None else sc.wave_yaw.components(np.random.default_rng([seed, 2]))
        self.truth = TruthModel(sc.ship, sc.current, sc.water, sc.loading, sc.waves.components(env_rng), self.frame,
                                sc.start_epoch, yaw, marks_read_sea=sc.marks_read_sea)
        self.sensor_rngs = [s.rng(seed) for s in sc.sensors]
        self.spell_rngs = [s.spell_rng(seed) if s.dropout_spells else None for s in sc.sensors]
        self.outputs = [[output(k) for k in s.outputs] for s in sc.sensors]
        #: Per sensor, its last reported values (what a frozen sensor goes on repeating).
        self.last_values: list[dict[str, float]] = [{} for _ in sc.sensors]
        self.fault_rng = np.random.default_rng([seed, 1])
        self.injected: Counter = Counter()  #: damage by reason
        self.dropped: Counter = Counter()  #: lost samples by sensor
        self.records: Counter = Counter()  #: records by output key
        self.t = 0.0

    def chunks(self, chunk_s: float = 300.0) -> Iterator[Chunk]:
        while self.t < self.duration - 1e-9:
            yield self.advance(min(self.t + chunk_s, self.duration))

    def advance(self, end_s: float) -> Chunk:
        """Simulate [t, end_s) and return its truth rows and records."""
        sc, start_s = self.scenario, self.t
        self.truth.begin(self.integrator.advance(end_s))
        start_ms, end_ms = int(round(start_s * 1000)), int(round(end_s * 1000))
        truth_ms = _grid_ms(sc.truth_rate_hz, start_ms, end_ms)
        truth_rows = self.truth.sample(truth_ms / 1000.0)
        buses: dict[str, list[Batch]] = {"nmea": [], "can": []}
        cache: dict[tuple[int, int], dict[str, np.ndarray]] = {}
        epoch_ms = sc.start_epoch * 1000
        for si, (spec, rng, outs) in enumerate(zip(sc.sensors, self.sensor_rngs, self.outputs)):
            spell_rng = self.spell_rngs[si]
            t_ms = spec.sample_times_ms(start_ms, end_ms)
            if t_ms.size == 0:
                continue
            key = (spec.period_ms, spec.offset_ms)
            if key not in cache:
                cache[key] = self.truth.sample(t_ms / 1000.0)
            values = measure(spec, cache[key], rng, self.frame)
            if spec.frozen:
                values = freeze(spec, t_ms / 1000.0, values, self.last_values[si])
            keep = kept(spec, t_ms / 1000.0, rng, spell_rng)
            self.dropped[spec.name] += int((~keep).sum())
            if not keep.any():  # a chunk inside an outage: nothing to encode
                continue
            idx = t_ms // spec.period_ms
            values = {k: v[keep] for k, v in values.items()}
            idx, t_abs = idx[keep], t_ms[keep] + epoch_ms
            for oi, (name, out) in enumerate(zip(spec.outputs, outs)):
                bus, batch = out(spec, idx, t_abs, values, si * 16 + oi)
                self.records[name] += len(batch.payload)
                buses[bus].append(batch)
        nmea, can = Batch.merge(buses["nmea"]), Batch.merge(buses["can"])
        if sc.faults.any:
            nmea, can = self._damage(nmea), self._damage_can(can)
        self.t = end_s
        return Chunk(start_s, end_s, truth_rows, nmea, can)

    def _damage(self, nmea: Batch) -> Batch:
        lines, after = damage_nmea(list(nmea.payload), self.scenario.faults, self.fault_rng, self.injected)
        if not after:
            return Batch(nmea.t_us, nmea.key, lines)
        t, key = list(nmea.t_us.tolist()), list(nmea.key.tolist())
        for i in reversed(after):
            lines.insert(i + 1, garbage_line(self.fault_rng))
            t.insert(i + 1, t[i])
            key.insert(i + 1, -1)  # marks a line that is written without a TAG block
        return Batch(np.array(t, np.int64), np.array(key, np.int64), lines)

    def _damage_can(self, can: Batch) -> Batch:
        dbc_rows = [i for i, (_, ext, _) in enumerate(can.payload) if not ext]
        mask = damage_frames(len(dbc_rows), self.scenario.faults, self.fault_rng, self.injected)
        for i in np.asarray(dbc_rows)[mask].tolist():
            fid, ext, data = can.payload[i]
            can.payload[i] = (fid, ext, data[:2])
        return can

    def meta(self) -> dict:
        """What was run and what was injected, for meta.json."""
        from dataclasses import asdict

        sc = self.scenario
        return {
            "scenario": sc.name,
            "description": sc.description,
            "seed": self.seed,
            "duration_s": self.duration,
            "start_time": sc.start_epoch,
            "start_time_iso": np.datetime64(sc.start_epoch, "s").astype(str) + "Z",
            "origin": {"lat": sc.origin[0], "lon": sc.origin[1]},
            "ship": asdict(sc.ship),
            "integration_step_s": sc.dt,
            "heading_deg": sc.heading_deg,
            "overrides": dict(self.overrides),
            "helm": {"type": type(sc.helm).__name__, **asdict(sc.helm), "fired": self.helm.fired},
            "current": asdict(sc.current),
            "water": asdict(sc.water),
            "waves": {"type": type(sc.waves).__name__, **asdict(sc.waves)},
            "loading": asdict(sc.loading),
            **({} if sc.wave_yaw is None else {"wave_yaw": asdict(sc.wave_yaw)}),
            "can_channel": sc.can_channel,
            "sensors": [_sensor_meta(s) for s in sc.sensors],
            "faults": {
                "spec": asdict(sc.faults),
                "injected": dict(sorted(self.injected.items())),
                "dropouts": {k: v for k, v in sorted(self.dropped.items()) if v},
                "windows": [w for s in sc.sensors for w in s.windows()],
                "position_jumps": [
                    {"sensor": s.name, "start_s": a, "end_s": b, "north_m": n, "east_m": e}
                    for s in sc.sensors for a, b, n, e in s.jumps
                ],
            },
            "records": dict(sorted(self.records.items())),
            "truth_columns": list(columns()),
        }


def _sensor_meta(s) -> dict:
    from dataclasses import asdict

    d = asdict(s)
    d["noise"], d["bias"], d["quantum"] = dict(s.noise), dict(s.bias), dict(s.quantum)
    if not s.frozen:
        del d["frozen"]  # the meta.json of a sensor without the newer fault stays as it was
    return d


def _grid_ms(rate_hz: float, start_ms: int, end_ms: int) -> np.ndarray:
    p = int(round(1000.0 / rate_hz))
    first = -(-start_ms // p)
    return np.arange(first, math.ceil(end_ms / p), dtype=np.int64) * p
