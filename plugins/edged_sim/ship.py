"""The vessel: particulars and the 3-DOF manoeuvring model (surge, sway, yaw).

Model: a first-order Nomoto yaw model with Norrbin's cubic term (so that hard-over
turns settle at a realistic rate instead of the linear model's far too tight circle), a
first-order sway (drift) model whose steady state puts the pivot point `pivot·L` ahead
of midships, and a quadratic-resistance surge model with the centripetal `v·r` term and
rudder drag, which gives the 30–50 % speed loss of a hard-over turn. The indices are in
Norrbin's non-dimensional (prime) form, so one set fits a range of sizes and speeds;
the rudder's side force and drag follow from the particulars (a rudder of `L·T/60`,
lift slope 2 per radian, hull mass with added mass).

The current is kinematic: it moves the hull over ground but exerts no force, so the
model is written in water-relative velocities and the current's displacement is added
afterwards (see `trace.py`). That keeps the integration loop free of the environment.

Body axes: x forward, y starboard, z down; r > 0 turning to starboard; rudder angle > 0
is a starboard order (bow swings to starboard).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: State layout of the integrated vector.
STATE = ("n_w", "e_w", "u", "v", "psi", "r", "delta")
N_STATE = len(STATE)


@dataclass(frozen=True)
class ShipParticulars:
    """Main dimensions and manoeuvring indices of one ship."""

    name: str = "container ship"
    length: float = 175.0  #: m, between perpendiculars
    beam: float = 25.4  #: m
    draft: float = 8.5  #: m, design (static) draft
    block_coefficient: float = 0.56
    #: Nomoto gain and time constant, non-dimensional (K' = K·L/U, T' = T·U/L).
    nomoto_k: float = 2.0
    nomoto_t: float = 2.0
    #: Norrbin's cubic yaw damping (non-dimensional); sets the hard-over turning rate.
    norrbin: float = 2.0
    #: Pivot point ahead of midships as a fraction of L (steady drift v = −pivot·L·r).
    pivot: float = 0.3
    #: Sway time constant, non-dimensional (T_v·U/L).
    sway_t: float = 0.6
    #: Surge "resistance length" in ship lengths: u̇ = (u_T² − u²)/(surge_l·L).
    surge_l: float = 10.0
    #: Centripetal coupling of sway and yaw into surge ((m + m_y)/(m + m_x) ≈ 1.2).
    surge_vr: float = 1.2
    rudder_max: float = math.radians(35.0)
    rudder_rate: float = math.radians(2.5)  #: rad/s, steering gear (IMO ≤ 28 s 35°→−30°)
    rudder_t: float = 0.5  #: s, servo time constant below the rate limit

    @property
    def rudder_lift(self) -> float:
        """Sway acceleration per (U²·rad): ½ρU²·A_R·C_Lα / (2ρ·C_b·L·B·T)."""
        return 1.0 / (120.0 * self.block_coefficient * self.beam)

    @property
    def rudder_drag(self) -> float:
        """Surge deceleration per (U²·rad²), the induced drag of the same rudder."""
        return 1.0 / (63.0 * self.block_coefficient * self.beam)


def derivative(s: tuple[float, ...] | list[float], delta_c: float, u_t: float, p: ShipParticulars) -> tuple[float, ...]:
    """Time derivative of the state under the orders (rudder command, thrust speed).

    Plain floats on purpose: numpy's per-call overhead on a 7-vector is larger than the
    arithmetic, and this runs four times per step for hours of simulated time.
    """
    _, _, u, v, psi, r, delta = s
    length = p.length
    speed = math.sqrt(u * u + v * v)
    big_u = speed if speed > 0.5 else 0.5  # keeps the prime system finite when stopped
    c, sn = math.cos(psi), math.sin(psi)

    rate = (delta_c - delta) / p.rudder_t
    rate = min(max(rate, -p.rudder_rate), p.rudder_rate)

    r_prime = r * length / big_u
    r_dot = (p.nomoto_k * delta - r_prime - p.norrbin * r_prime**3) * big_u * big_u / (p.nomoto_t * length * length)
    u2 = big_u * big_u
    v_dot = (-p.pivot * length * r - v) * big_u / (p.sway_t * length) - p.rudder_lift * u2 * delta
    u_dot = (
        (u_t * abs(u_t) - u * abs(u)) / (p.surge_l * length)
        + p.surge_vr * v * r
        - p.rudder_drag * u2 * delta * delta
    )
    return (u * c - v * sn, u * sn + v * c, u_dot, v_dot, r, r_dot, rate)


def steady_thrust_speed(u_ref: float, u_ref_dot: float, p: ShipParticulars) -> float:
    """Thrust speed that makes the surge model follow a speed reference (feed-forward)."""
    sq = u_ref * abs(u_ref) + p.surge_l * p.length * u_ref_dot
    return math.copysign(math.sqrt(abs(sq)), sq)
