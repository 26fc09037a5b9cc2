"""What a scenario is: ship, orders, sea, sensors, faults — all data."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from .environment import Current, Water
from .faults import FaultSpec
from .helm import Autopilot, Manoeuvre, ZigZag
from .sensors import SensorSpec
from .ship import ShipParticulars
from .truth import Loading
from .waves import Calm, JonswapWaves, RegularWaves, WaveYaw


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    duration_s: float
    ship: ShipParticulars
    helm: Manoeuvre | ZigZag | Autopilot
    heading_deg: float
    sensors: tuple[SensorSpec, ...]
    current: Current = field(default_factory=Current)
    water: Water = field(default_factory=Water)
    waves: Calm | RegularWaves | JonswapWaves = field(default_factory=Calm)
    loading: Loading = field(default_factory=Loading)
    faults: FaultSpec = field(default_factory=FaultSpec)
    origin: tuple[float, float] = (57.60, 11.50)  #: lat, lon of the start (Kattegat)
    start_epoch: int = 1732350000  #: fixed, so that a seed gives the same bytes
    dt: float = 0.05  #: s, integration step
    truth_rate_hz: float = 10.0
    can_channel: str = "can0"
    #: The hull's wave-frequency yaw on top of the manoeuvring yaw (small craft); None: none.
    wave_yaw: WaveYaw | None = None
    #: The draft marks read the sea at their own positions as well as the hull's motion
    #: (`waves.sea_at`): each mark its own phase of a sea travelling along the hull.
    marks_read_sea: bool = False

    def without_errors(self) -> "Scenario":
        """Perfect sensors and no faults: the logs then carry the truth to the formats'
        resolution, which is what encoding tests compare."""
        return replace(self, sensors=tuple(s.without_errors() for s in self.sensors), faults=FaultSpec())
