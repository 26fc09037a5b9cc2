"""Watchers that turn what the filter sees into health `problems` (DESIGN §2, Health).

Two things a crew must be told while they last, each from the data alone:
- `NisWatch`: a measurement whose normalised innovations stay far outside their χ²
  band (the filter and that sensor disagree: a wrong σ, a fault, a divergence). Far
  outside: over a full window the NIS mean is beyond 4× its dof, or it is above the
  dof with under half of the updates inside the two-sided 95 % band, or more than
  half of the recent readings were gated; for long: continuously for `hold` s of data time.
  A consistent filter's window mean over 100 updates has σ √(2·dof/100): 4× the dof
  is more than 20 σ away, so a healthy filter never trips it.
- `LogWatch`: the Doppler/EM log reading what the water cannot be doing: near 0 (a
  fouled or dead transducer) while the vessel makes way through the water, or
  rejected by the fit's gate reading after reading. While it lasts the log is left
  out of the fit and named in `problems`; it is taken back after `clear` s of plausible
  readings.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

#: The NIS window must hold this many updates before it may raise a problem.
NIS_MIN_WINDOW = 30
NIS_FAR = 4.0


@dataclass
class NisWatch:
    hold: float = 120.0
    _since: dict[str, float] = field(default_factory=dict)
    problems: dict[str, str] = field(default_factory=dict)

    def check(self, t: float, innovation: dict[str, dict[str, Any]], gated_recent: dict[str, float]) -> None:
        """`innovation` is the monitor's snapshot; `gated_recent` the share of gated
        readings per kind over the recent window."""
        for kind, s in innovation.items():
            n, mean, inside, dof = s.get("window") or 0, s.get("nis_mean"), s.get("in_band_95"), s.get("dof", 1)
            gated = gated_recent.get(kind, 0.0)
            why = None
            if gated > 0.5:
                why = f"{100 * gated:.0f} % of its recent readings rejected by the gate"
            elif n >= NIS_MIN_WINDOW and mean is not None and inside is not None:
                # Only too large: a NIS far under its dof is a σ set too wide (an
                # honest, if wasteful, estimate), not a disagreement.
                if mean > NIS_FAR * dof or (inside < 0.5 and mean > dof):
                    why = (f"NIS mean {mean:.3g} over its last {n} updates ({dof} dof; "
                           f"{100 * inside:.0f} % inside the 95 % band)")
            if why is None:
                self._since.pop(kind, None)
                self.problems.pop(kind, None)
                continue
            t0 = self._since.setdefault(kind, t)
            if t - t0 >= self.hold:
                self.problems[kind] = f"{kind}: {why} for {t - t0:.0f} s: the filter and this measurement disagree"


@dataclass
class LogWatch:
    """A log reading near zero while the vessel makes way, or gated on and on."""

    min_speed: float
    hold: float = 60.0
    clear: float = 30.0
    zero: float = 0.1  #: m/s: a log reading below this is "0"
    _bad_since: float | None = None
    _good_since: float | None = None
    why: str | None = None
    problem: str | None = None

    def reading(self, t: float, z: float, stw: float | None, stw_std: float | None, gated: bool | None) -> None:
        """One log reading beside the estimate (stw None: no estimate yet); `gated`:
        the fit's verdict (None: not tried)."""
        bad = None
        if stw is not None and stw_std is not None and stw - 3.0 * stw_std > max(self.min_speed, 2.0 * self.zero) \
                and abs(z) < self.zero:
            bad = f"reads {z:.2f} m/s while the estimate is {stw:.2f} ± {stw_std:.2f} m/s through the water"
        elif gated:
            bad = "disagrees with the estimate beyond its gate"
        if bad is not None:
            self._good_since = None
            if self._bad_since is None:
                self._bad_since = t
            self.why = bad
            if t - self._bad_since >= self.hold:
                self.problem = f"Doppler log {bad} for {t - self._bad_since:.0f} s: left out of the fit"
            return
        if stw is None or gated is None and self.problem is None:
            return
        if self._good_since is None:
            self._good_since = t
        if self.problem is None or t - self._good_since >= self.clear:
            self._bad_since = None
            self.problem = None
            self.why = None

    @property
    def left_out(self) -> bool:
        return self.problem is not None
