"""The sea around the hull: current, water depth and channel, squat.

Currents are functions of time only (the tracks are short against the scales on which
a current varies in space); each gives its velocity and its time derivative in closed
form, because the accelerometer truth needs dV/dt and a numerical derivative of a
slowly rotating vector would be needlessly noisy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from edged.units import KNOT


@dataclass(frozen=True)
class Current:
    """A current flowing toward `set_deg`, rotating at `rotation_deg_h` and with its
    speed varying by `drift_amplitude` over `drift_period_s` around `drift`.

    Constant: leave the rates at zero. Rotating across the track: a rotation rate.
    Slowly varying: a drift amplitude and period.
    """

    set_deg: float = 0.0
    drift: float = 0.0  #: m/s
    rotation_deg_h: float = 0.0
    drift_amplitude: float = 0.0
    drift_period_s: float = 3600.0

    def velocity(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(v_north, v_east, a_north, a_east) at times t (s)."""
        t = np.asarray(t, dtype=float)
        w = np.radians(self.rotation_deg_h) / 3600.0
        ang = np.radians(self.set_deg) + w * t
        wd = 2.0 * np.pi / self.drift_period_s
        speed = self.drift + self.drift_amplitude * np.sin(wd * t)
        speed_dot = self.drift_amplitude * wd * np.cos(wd * t)
        c, s = np.cos(ang), np.sin(ang)
        return speed * c, speed * s, speed_dot * c - speed * w * s, speed_dot * s + speed * w * c

    def displacement(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """∫₀ᵗ V dt, north and east (m), by Simpson's rule on the given grid.

        Simpson is what RK4 reduces to for a time-only right-hand side, so the current's
        share of the track is integrated to the same order as the hull's.
        """
        t = np.asarray(t, dtype=float)
        mid = 0.5 * (t[1:] + t[:-1])
        vn, ve, _, _ = self.velocity(t)
        mn, me, _, _ = self.velocity(mid)
        h = np.diff(t) / 6.0
        dn = np.concatenate(([0.0], np.cumsum(h * (vn[:-1] + 4.0 * mn + vn[1:]))))
        de = np.concatenate(([0.0], np.cumsum(h * (ve[:-1] + 4.0 * me + ve[1:]))))
        return dn, de


@dataclass(frozen=True)
class Water:
    """Depth below the waterline and, in a channel, its width (None = open water)."""

    depth: float = 60.0
    channel_width: float | None = None


def barrass_squat(stw: np.ndarray, draft: np.ndarray, beam: float, cb: float, water: Water) -> np.ndarray:
    """Maximum squat (m) by Barrass: S_max = K·C_b·V²/100, V in knots, K = 5.74·S^0.76.

    S is the blockage b·T / (W·h); in open water W is Barrass's width of influence
    7.04·B / C_b^0.85. Barrass's formula is for shallow water (h/T up to about 1.5);
    deeper than that the squat is taken as zero rather than extrapolated. S below 0.1
    is the open-water end of the formula (K = 1).
    """
    draft = np.asarray(draft, dtype=float)
    width = water.channel_width if water.channel_width is not None else 7.04 * beam / cb**0.85
    blockage = np.maximum(beam * draft / (width * water.depth), 0.1)
    k = 5.74 * blockage**0.76
    v_kn = np.asarray(stw, dtype=float) / KNOT
    squat = k * cb * v_kn * v_kn / 100.0
    return np.where(water.depth / draft <= 1.5, squat, 0.0)
