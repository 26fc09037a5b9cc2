"""The GNSS against the estimate: a fix too far to be true, a SOG/COG the estimate has
left behind, a position and a velocity of one epoch both beyond their gates.

Each check keeps its own run and says what it found; the core acts on it (holds the
fix out, moves the position, starts the filter again), so that every reset is counted
in one place.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from .cmm import Cmm
from .ctra import Ctra

#: A fix this far from the estimate (m, and JUMP_SIGMAS of its σ) is held out for
#: JUMP_HOLD s before it is taken as the position (`GnssChecks.far`).
JUMP_FAR = 500.0
JUMP_SIGMAS = 10.0
JUMP_HOLD = 120.0
#: The estimate's velocity this far from the GNSS's SOG/COG (m/s, and σ) SOG_OFF_RUN
#: times in a row is a diverged filter; SOG_SIGMA is the receiver's own (m/s).
SOG_OFF = 2.0
SOG_OFF_SIGMAS = 6.0
SOG_OFF_RUN = 5
SOG_SIGMA = 0.2
#: A GNSS position and velocity this close in time (s) are one epoch: both beyond their
#: gates is one story, a manoeuvre the filter missed, not two outliers
#: (`GnssChecks.one_epoch_gated`).
GNSS_EPOCH = 0.5

Far = Literal["near", "held", "jump"]


class GnssChecks:
    def __init__(self) -> None:
        self._far_since: dict[str, float] = {}  # position source -> first fix far off the track
        self._far_what = ""
        self._sog_off = 0  # SOG/COG measurements in a row far from the estimate
        self._gated: dict[str, float] = {}  # kind → data time of its last gated update

    def far(self, t: float, z: np.ndarray, source: str, x: np.ndarray, P: np.ndarray) -> Far:
        """A fix farther from the estimate than the vessel could have gone (JUMP_FAR m
        and JUMP_SIGMAS σ) is `held` out for JUMP_HOLD s: a receiver's glitch of 10 km
        for a minute must not move a ship the GNSS's own SOG and the other sensors say
        held her course. The filter coasts meanwhile, its position σ growing, and
        health names the fixes. Still there after JUMP_HOLD, they are the position
        (`jump`)."""
        d = float(np.hypot(z[0] - x[0], z[1] - x[1]))
        sigma = math.sqrt(max(float(P[0, 0] + P[1, 1]), 0.0))
        if d <= max(JUMP_FAR, JUMP_SIGMAS * sigma):
            self._far_since.pop(source, None)
            return "near"
        since = self._far_since.setdefault(source, t)
        if t - since < JUMP_HOLD:
            self._far_what = f"position/{source}: fixes {d / 1000.0:.1f} km from the track for {t - since:.0f} s, kept out"
            return "held"
        del self._far_since[source]
        return "jump"

    def sog_off(self, vn: float, ve: float, model: Ctra | Cmm, x: np.ndarray, P: np.ndarray) -> float | None:
        """The GNSS's own SOG/COG against the estimate's velocity over ground: SOG_OFF_RUN
        in a row beyond SOG_OFF_SIGMAS σ and SOG_OFF m/s is a filter that has lost
        itself (saturated accelerometers once took it to 457 m/s): how far off (m/s)
        then, else None."""
        en, ee = model.ground_velocity(x)
        body_var = model.body_var(x, P)
        sigma = math.sqrt(max(float(body_var[0] + body_var[1]), 0.0) + SOG_SIGMA**2)
        off = math.hypot(en - vn, ee - ve)
        if off > max(SOG_OFF, SOG_OFF_SIGMAS * sigma):
            self._sog_off += 1
            if self._sog_off >= SOG_OFF_RUN:
                self._sog_off = 0
                return off
        else:
            self._sog_off = 0
        return None

    def one_epoch_gated(self, kind: str, t: float) -> bool:
        """A position or velocity (`kind`) kept out by its gate at t: True when the
        other was too, within GNSS_EPOCH s (one epoch: the vessel did what the filter
        did not expect)."""
        other = self._gated.get("velocity" if kind == "position" else "position")
        self._gated[kind] = t
        if other is None or abs(t - other) > GNSS_EPOCH:
            return False
        self._gated.clear()
        return True

    def problem(self) -> str | None:
        """Health's words for fixes held out now."""
        return self._far_what if self._far_since and self._far_what else None

    def forget(self) -> None:
        """The filter starts again: nothing it was compared with holds."""
        self._far_since.clear()
        self._sog_off = 0
        self._gated.clear()
