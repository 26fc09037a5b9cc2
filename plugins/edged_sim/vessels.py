"""The vessels of the generalisation grid: a 12 m yacht in a seaway, a 110 m coaster, a
300 m tanker; each with the voyage and the sea it sails in.

The manoeuvring indices are Norrbin's non-dimensional ones (`ship.ShipParticulars`),
so the same model spans the sizes; the values are the usual ranges for the type
(Nomoto's K' ≈ 1.5–3, T' ≈ 1–4: small agile hulls at the low T' end, full-bodied
tankers at the high end; Fossen 2011 §7.1 tables; Clarke et al. 1983 for the trends with
C_b and L/B). Hull speed of a displacement yacht: 1.34·√LWL[ft] kn (LWL 8.5 m gives
7.1 kn).

The voyage is the same pattern for every vessel, repeated every 20 minutes so that a
short run and a three-hour run both hold turns, speed changes and straight legs:
at 2 min a course change of 90° to starboard (steered by an autopilot, `helm.Autopilot`,
within ± `rudder_deg`), at 7 min the speed ordered down to 70 %, at 12 min the course
back to port, at 17 min the cruising speed again. A
steady current of 0.5 m/s sets across and along the legs (the STW estimator's case).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .environment import Current, Water
from .helm import Autopilot, Leg
from .ship import ShipParticulars
from .truth import Loading
from .waves import JonswapWaves, WaveYaw

#: Start heading and the heading of the second leg (°).
HEADINGS = (45.0, 135.0)
CYCLE_S = 1200.0
#: Enough cycles for a 6-h run (the helm plays its steps in order, then holds the last).
CYCLES = 20


@dataclass(frozen=True)
class Vessel:
    name: str
    description: str
    ship: ShipParticulars
    cruise_kn: float
    rudder_deg: float  #: the autopilot's rudder limit in the voyage's turns
    waves: JonswapWaves
    loading: Loading
    water: Water = field(default_factory=lambda: Water(depth=80.0))
    current: Current = field(default_factory=lambda: Current(set_deg=200.0, drift=0.5))
    wave_yaw: WaveYaw | None = None

    def voyage(self) -> Autopilot:
        """The repeated 20-minute pattern (module docstring) from HEADINGS[0]."""
        a, b = HEADINGS
        slow = round(0.7 * self.cruise_kn, 3)
        legs: list[Leg] = []
        for k in range(CYCLES):
            t0 = 120.0 + k * CYCLE_S
            legs += [Leg(t0, heading_deg=b), Leg(t0 + 300.0, speed_kn=slow, ramp_s=60.0),
                     Leg(t0 + 600.0, heading_deg=a), Leg(t0 + 900.0, speed_kn=self.cruise_kn, ramp_s=120.0)]
        return Autopilot(self.cruise_kn, tuple(legs), heading_deg=a, rudder_max_deg=self.rudder_deg)


YACHT = Vessel(
    "yacht", "12 m sailing/motor yacht (LWL 8.5 m, hull speed 7 kn) at 6 kn in a 1 m / 4.5 s sea, "
    "yawing ±5° at 3–6 s",
    ShipParticulars("12 m yacht", 8.5, 3.9, 1.9, 0.40, nomoto_k=2.5, nomoto_t=1.2, norrbin=2.0, pivot=0.3,
                    sway_t=0.5, surge_l=8.0, rudder_rate=0.087, rudder_t=0.3),
    cruise_kn=6.0, rudder_deg=15.0,
    waves=JonswapWaves(1.0, 4.5, from_deg=10.0), water=Water(depth=30.0),
    loading=Loading(draft_knots=((0.0, 1.9),), roll_period=3.5, roll_damping=0.15),
    wave_yaw=WaveYaw(5.0, 3.0, 6.0),
)

COASTER = Vessel(
    "coaster", "110 m coaster (C_b 0.75) at 12 kn in a 1.5 m / 7 s sea",
    ShipParticulars("110 m coaster", 110.0, 16.5, 6.0, 0.75, nomoto_k=1.9, nomoto_t=1.9),
    cruise_kn=12.0, rudder_deg=15.0,
    waves=JonswapWaves(1.5, 7.0, from_deg=10.0),
    loading=Loading(draft_knots=((0.0, 6.0),), roll_period=10.0),
)

TANKER = Vessel(
    "tanker", "300 m tanker (VLCC, C_b 0.82) at 14 kn in a 2.5 m / 10 s sea: sluggish (T' 3.5)",
    ShipParticulars("300 m tanker", 300.0, 56.0, 20.0, 0.82, nomoto_k=1.5, nomoto_t=3.5, norrbin=3.0,
                    rudder_rate=0.0407),
    cruise_kn=14.0, rudder_deg=20.0,
    waves=JonswapWaves(2.5, 10.0, from_deg=10.0), water=Water(depth=60.0),
    loading=Loading(draft_knots=((0.0, 20.0),), roll_period=16.0),
)

VESSELS: dict[str, Vessel] = {v.name: v for v in (YACHT, COASTER, TANKER)}
