"""The demo's truth.csv: the simulated vessel's true state on the recording's clock.

Why: `edged score` and `edged plot --truth` judge a recording against truth, and the
live demo plays a simulation whose truth is known. The simulator (`LiveVessel`) sends
records only; the same scenario and seed simulated again give the same truth (the
truth depends on the seed alone, not on how the run is cut into chunks), so it is
simulated again here, alongside, one second at a time (a few milliseconds of a core
per second), and written with its times moved from the scenario's fixed start to the
moment the live vessel started: its first reading of its clock, which `OriginClock`
notes (`LiveVessel.run` sends each record at that reading plus the record's time in
the scenario).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import IO, Any

import numpy as np

from edged.clock import Clock

#: Seconds of scenario per simulated chunk: the live vessel's own (`LiveVessel.chunk_s`).
CHUNK_S = 1.0


class OriginClock:
    """A clock that notes its first reading (`origin`): the live vessel's start."""

    def __init__(self, clock: Clock) -> None:
        self._clock = clock
        self.origin: float | None = None

    def now(self) -> float:
        t = self._clock.now()
        if self.origin is None:
            self.origin = t
        return t

    def monotonic(self) -> float:
        return self._clock.monotonic()


class TruthWriter:
    """Writes `path` as the live vessel plays: `advance(t)` up to the clock's time `t`,
    `finish(t)` at the end (rows up to `t` only). Nothing is written before the vessel
    started (no origin yet)."""

    def __init__(self, path: Path, scenario: str, seed: int, clock: OriginClock) -> None:
        from edged_sim.run import Simulation
        from edged_sim.scenarios import SCENARIOS

        self.path = path
        self.clock = clock
        self.sim = Simulation(SCENARIOS[scenario], seed, duration=math.inf)
        self.rows = 0
        #: Seconds the vessel played (set by `finish`).
        self.played = 0.0
        self._file: IO[str] | None = None

    def _write(self, truth: dict[str, np.ndarray], origin: float, upto: float | None = None) -> None:
        from edged_sim.truth import columns
        from edged_sim.writers import write_truth

        if self._file is None:
            self._file = open(self.path, "w", encoding="ascii", newline="\n")
            self._file.write(",".join(columns()) + "\n")
        rows: dict[str, Any] = dict(truth)
        if upto is not None:
            keep = rows["t_rel"] <= upto
            rows = {k: v[keep] for k, v in rows.items()}
        rows["t"] = origin + rows["t_rel"]
        write_truth(self._file, rows)
        self.rows += len(rows["t"])

    def advance(self, t: float) -> None:
        """Simulate and write every whole chunk the vessel has played by time `t`."""
        origin = self.clock.origin
        if origin is None:
            return
        while self.sim.t + CHUNK_S <= t - origin:
            self._write(self.sim.advance(self.sim.t + CHUNK_S).truth, origin)

    def finish(self, t: float) -> Path | None:
        """The rest up to time `t`, and the file closed; the file (None when the
        vessel never started)."""
        origin = self.clock.origin
        try:
            if origin is None:
                return None
            self.played = max(0.0, t - origin)
            self.advance(t)
            if self.sim.t < self.played:
                self._write(self.sim.advance(self.sim.t + CHUNK_S).truth, origin, upto=self.played)
        finally:
            if self._file is not None:
                self._file.close()
        return self.path if self._file is not None else None

    def rename(self, path: Path) -> None:
        """Move the finished file (beside the recording it goes with, named after it)."""
        self.path = self.path.replace(path)
