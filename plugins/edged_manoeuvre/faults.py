"""A sensor that is in range for its interface but not for a hull: saturated, frozen.

Why: a saturated accelerometer (0x320 reading 32.767 m/s², the int16's largest value,
which its DBC accepts) is a sensor fault, not a manoeuvre; the innovation gate keeps
it out five times, then lets it in as "a real change", and the filter diverged to a
SOG of 457 m/s. A compass that freezes (repeating its last heading for ten minutes)
pulls the filter's heading with it while the rate gyro says the ship turns; its σ
stays 0.001 rad while the error reaches 0.3 rad. Both are found from the data alone:
- **range**: what a hull can do. Horizontal accelerations beyond ACCEL_MAX (a planing
  launch in a seaway reaches a few m/s²; 5 m/s² is half a g), a rate of turn beyond
  RATE_MAX (a 12 m yacht tacks at 20–30 °/s).
- **frozen**: a reading repeated exactly, every row, for FROZEN_COUNT readings (and
  FROZEN_SPAN seconds for an accelerometer: noise makes that impossible, its last
  digits move). A compass holding a steady course at 0.1° resolution may repeat
  itself, so a heading is frozen only when the rate gyro turned the ship by more than
  FROZEN_TURN meanwhile; the filter, which took it until then, is told to doubt its
  heading by that turn (`new_doubt`). A rate of turn is never judged so
  (`FROZEN_KINDS`).
A reading judged so is left out (`rejected.<kind>.range` / `.frozen`) and named in
health's `problems` for as long as it lasts and FAULT_MEMORY seconds after.
"""

from __future__ import annotations

import math

import numpy as np

from .model import say

DEG = math.pi / 180.0
ACCEL_MAX = 5.0  # m/s², per horizontal axis
RATE_MAX = 60.0 * DEG  # rad/s
FROZEN_COUNT = 10
FROZEN_SPAN = 5.0  # s
FROZEN_TURN = 2.0 * DEG  # rad of turn by the rate gyro while a compass repeats itself
#: A compass repeating itself SUSPECT_COUNT times while the gyro turned the ship more
#: than SUSPECT_SIGMAS of its σ (and SUSPECT_TURN) is left out until it moves again.
SUSPECT_COUNT = 3
SUSPECT_SIGMAS = 3.0
SUSPECT_TURN = 0.2 * DEG
FAULT_MEMORY = 10.0  # s
#: Kinds that can be judged frozen: a rate of turn is not (NMEA ROT's 0.1°/min
#: resolution reads +0.0 for minutes on a steady course).
FROZEN_KINDS = frozenset({"heading", "accel"})


class _Stream:
    __slots__ = ("value", "since", "count", "turn", "bad_since", "bad_t", "why", "suspect")

    def __init__(self) -> None:
        self.value: tuple[float, ...] | None = None
        self.since = 0.0
        self.count = 0
        self.turn = 0.0  # the rate gyro's turn since the value began repeating
        self.bad_since: float | None = None
        self.bad_t = -math.inf
        self.why = ""
        self.suspect = False


class SensorFaults:
    """Per (kind, source): is the reading possible for a hull, and is it alive?"""

    def __init__(self) -> None:
        self._streams: dict[tuple[str, str], _Stream] = {}
        self._rate: tuple[float, float] | None = None  # the last yaw rate taken (t, r)
        #: Variance (rad²) the filter's heading should take on, set when a compass is
        #: found frozen: it was used until then, through the gyro's turn since.
        self.new_doubt = 0.0

    def judge(self, kind: str, source: str, t: float, z: np.ndarray, sigma: float = 0.0) -> str | None:
        """None when the reading may be used, else why not ("range", "frozen");
        `sigma` is the source's 1-σ (a compass's: how far the ship may turn while it
        repeats itself before the repetition is suspect)."""
        s = self._streams.get((kind, source))
        if s is None:
            s = self._streams[(kind, source)] = _Stream()
        why = None
        value = tuple(z.tolist())
        if kind == "accel" and max(map(abs, value)) > ACCEL_MAX:
            why = "range"
            s.why = f"reading {max(map(abs, value)):.3g} m/s², beyond what a hull does (saturated?)"
        elif kind == "yaw_rate" and abs(value[0]) > RATE_MAX:
            why = "range"
            s.why = f"reading {value[0] / DEG:.1f}°/s, beyond what a hull does"
        if value == s.value:
            s.count += 1
        else:
            s.value, s.since, s.count, s.turn = value, t, 1, 0.0
        if why is None and kind in FROZEN_KINDS and s.count >= FROZEN_COUNT:
            # a compass that repeats itself while the rate gyro turns the ship, at once;
            # an accelerometer, after FROZEN_SPAN s of one exact reading
            if (kind == "heading" and abs(s.turn) > FROZEN_TURN) or (kind != "heading" and t - s.since >= FROZEN_SPAN):
                why = "frozen"
                s.why = f"frozen at {say(kind, z)} for {t - s.since:.0f} s"
        if why is None and kind == "heading" and s.count >= SUSPECT_COUNT and abs(s.turn) > max(
                SUSPECT_SIGMAS * sigma, SUSPECT_TURN):
            # suspect before it is found: left out, not named yet (a few readings of a
            # compass the gyro says is behind cost nothing; taking them pulls the
            # heading by the turn with a σ of a good compass). The ones taken before
            # are doubted: twice the turn since the repetition began.
            self.new_doubt = (2.0 * s.turn) ** 2 if not s.suspect else 0.0
            s.suspect = True
            return "suspect"
        s.suspect = False
        if kind == "yaw_rate" and why is None:
            self._advance_turn(t, float(z[0]))
        self.new_doubt = 0.0
        if why is not None:
            if s.bad_since is None:
                s.bad_since = t
                if why == "frozen" and kind == "heading":
                    # what the filter took of it before it was found: the turn since
                    self.new_doubt = s.turn * s.turn
            s.bad_t = t
        else:
            s.bad_since = None
        return why

    def _advance_turn(self, t: float, r: float) -> None:
        """The rate gyro's turn, added to every compass stream that is repeating itself."""
        if self._rate is not None and 0.0 < t - self._rate[0] <= 1.0:
            dpsi = 0.5 * (r + self._rate[1]) * (t - self._rate[0])
            for (kind, _), s in self._streams.items():
                if kind == "heading" and s.count >= 2:
                    s.turn += dpsi
        self._rate = (t, r)

    def problems(self, t: float | None) -> list[str]:
        if t is None:
            return []
        return [f"{kind}/{source}: {s.why}" for (kind, source), s in sorted(self._streams.items())
                if t - s.bad_t <= FAULT_MEMORY]

    def forget(self) -> None:
        """The filter started again: the gyro's turn counted so far belongs to no
        compass reading the new filter will take."""
        self._rate = None
        for s in self._streams.values():
            s.turn = 0.0
