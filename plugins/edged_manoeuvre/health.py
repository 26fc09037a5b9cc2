"""What the manoeuvre core's health says is wrong, beyond its counters: an input it
cannot do without, a hull moving sideways, innovations out of their band.

Monitoring (seed 002 §4): every update's NIS against its χ² band and rcond(S)
(eq. 23) are kept by `edged.innovation.InnovationMonitor`; a measurement kind whose
innovations stay far above their band is named here (`nis_problems`), as is a motion
no hull makes (`Sideways`). The core's `health()` puts them together.
"""

from __future__ import annotations

import math
from typing import Any

from .config import DEG

#: Health text of each input's absence.
COSTS = {
    "position": "no GNSS position: the filter cannot start",
    "heading": "no heading: the filter cannot start (sway needs the heading)",
    "yaw_rate": "no rate of turn: r is seen through the heading only",
    "accel_body": "no accelerometers: accelerations are seen through the GNSS only",
}
#: A measurement kind whose innovations stay this far above their χ² band over a full
#: window of updates (mean NIS above NIS_PROBLEM_MEAN × dof *and* fewer than
#: NIS_PROBLEM_IN_BAND of them inside the two-sided 95 % band: a few outliers lift the
#: mean alone) is named in health's `problems` (`ok: false`): the filter's model of that
#: sensor is wrong (a fault, a second source nobody separated, a noise beyond what the
#: adaptation may learn).
NIS_PROBLEM_MEAN = 5.0  # × dof
NIS_PROBLEM_IN_BAND = 0.5
NIS_PROBLEM_UPDATES = 50
#: A hull making way over ground faster than SIDEWAYS_SPEED m/s with a drift angle
#: between SIDEWAYS_ANGLE and 180° − SIDEWAYS_ANGLE for SIDEWAYS_SPAN s of data is
#: not possible (leeway is a few degrees; a cross current at this speed turns the track
#: by tens of degrees at most): the heading or the positions are wrong, and health
#: says so (Furuno's log: heading 143°, track 213° at 5.9 m/s).
SIDEWAYS_SPEED = 3.0
SIDEWAYS_ANGLE = 45.0 * DEG
SIDEWAYS_SPAN = 30.0


def missing(seen: dict[str, int]) -> dict[str, str]:
    """What each input never heard costs (health's `missing`)."""
    return {k: COSTS[k] for k in COSTS if not seen.get(k)}


class Sideways:
    """The time since which the estimate has moved sideways (`SIDEWAYS_*`)."""

    def __init__(self) -> None:
        self._since: tuple[float, float, float] | None = None  # since, drift angle, sog

    def judge(self, t: float, u: float, v: float, sog: float) -> None:
        drift = abs(math.atan2(v, u))
        if sog > SIDEWAYS_SPEED and SIDEWAYS_ANGLE < drift < math.pi - SIDEWAYS_ANGLE:
            since = self._since[0] if self._since is not None else t
            self._since = (since, drift, sog)
        else:
            self._since = None

    def problem(self, t: float | None) -> str | None:
        """Health's words at data time t, once the motion has lasted SIDEWAYS_SPAN s."""
        side = self._since
        if side is None or t is None or t - side[0] < SIDEWAYS_SPAN:
            return None
        return (f"heading: the hull moves sideways (drift angle {side[1] / DEG:.0f}° at {side[2]:.1f} m/s "
                f"over ground for {t - side[0]:.0f} s): the heading or the positions are wrong")

    def forget(self) -> None:
        self._since = None


def nis_problems(snapshot: dict[str, Any]) -> list[str]:
    """The measurement kinds whose innovations are out of their band (`NIS_PROBLEM_*`),
    from an `InnovationMonitor.snapshot()`."""
    out = []
    for kind, m in snapshot.get("innovation", {}).items():
        dof = m.get("dof") or 1
        if m.get("window", 0) < NIS_PROBLEM_UPDATES or m.get("nis_mean") is None:
            continue
        # too large only: a NIS too small (a static receiver repeating one fix) is a
        # σ that claims less than it knows, not an estimate that is wrong
        if m["nis_mean"] > NIS_PROBLEM_MEAN * dof and (m.get("in_band_95") or 0.0) < NIS_PROBLEM_IN_BAND:
            out.append(f"{kind}: innovations out of their band (NIS mean {m['nis_mean']:.3g} for {dof} dof, "
                       f"{m.get('in_band_95', 0.0):.0%} in the 95 % band over {m['window']} updates)")
    return out
