"""Scenarios composed from a vessel, a sensor suite and a sensor fault: the
generalisation grid of issue 30 (`edged sim VESSEL:SUITE[:FAULT]`).

`edged sim`'s options are a contract defined in edged/cli.py; composing by name needs
none: `edged sim tanker:fog`, `edged sim yacht:yacht`, `edged sim coaster:coastal:heading-frozen`.
The named fault scenarios (`fault-*` in `scenarios.SCENARIOS`) are such compositions.

A fault is a recipe that changes some of the suite's sensors over a window of the
run (`SensorSpec` outages, forced values, frozen values, position jumps) and sets a
duration that holds the window and the time to recover after it; the windows go into
meta.json (`faults.windows`, `faults.position_jumps`) as every sensor fault does.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

from .scenario import Scenario
from .sensors import SensorSpec
from .suites import SUITES, SuiteSpec
from .vessels import HEADINGS, VESSELS, Vessel

#: 0x320 ImuAccel's largest value (int16 32767 × 0.001 m/s²): a saturated accelerometer
#: still sends a number in range, not the "unavailable" code.
ACCEL_SATURATED = 32.767
SIX_HOURS = 6 * 3600.0


@dataclass(frozen=True)
class Fault:
    name: str
    description: str
    duration_s: float
    window: tuple[float, float]  #: s of the run
    #: The sensors it changes (by SensorSpec.model) and how.
    models: tuple[str, ...]
    change: Callable[[SensorSpec, tuple[float, float]], SensorSpec]

    def apply(self, sensors: tuple[SensorSpec, ...]) -> tuple[SensorSpec, ...]:
        """The suite with the fault; ValueError when the suite has no sensor it acts on."""
        hit = [s for s in sensors if not self.models or s.model in self.models]
        if not hit:
            raise ValueError(f"fault {self.name!r} needs a sensor of model {' or '.join(self.models)} "
                             "that this suite does not have")
        return tuple(self.change(s, self.window) if s in hit else s for s in sensors)


def _saturate(s: SensorSpec, w: tuple[float, float]) -> SensorSpec:
    return replace(s, forced=s.forced + tuple((*w, f, ACCEL_SATURATED) for f in ("ax", "ay", "az")))


def _silence(s: SensorSpec, w: tuple[float, float]) -> SensorSpec:
    return replace(s, outages=s.outages + (w,))


def _freeze(s: SensorSpec, w: tuple[float, float]) -> SensorSpec:
    return replace(s, frozen=s.frozen + (w,))


def _jump(s: SensorSpec, w: tuple[float, float]) -> SensorSpec:
    return replace(s, jumps=s.jumps + ((*w, 10_000.0, 0.0),))


def _dvl_zero(s: SensorSpec, w: tuple[float, float]) -> SensorSpec:
    return replace(s, forced=s.forced + ((*w, "stw_long", 0.0), (*w, "stw_trans", 0.0)))


#: The faults of issue 30 ("Under sensor faults").
FAULTS: dict[str, Fault] = {
    f.name: f
    for f in (
        Fault("accel-saturated", "accelerometers saturated (0x320 at 32.767 m/s², in range) for 10 s at 300 s",
              960.0, (300.0, 310.0), ("imu_accel",), _saturate),
        Fault("gap-6h", "every sensor silent for 6 hours from 600 s (a logger off), then 15 minutes more",
              600.0 + SIX_HOURS + 900.0, (600.0, 600.0 + SIX_HOURS), (), _silence),
        Fault("heading-frozen", "the compass repeating its last heading for 10 minutes from 600 s",
              1800.0, (600.0, 1200.0), ("heading",), _freeze),
        Fault("position-jump", "every GNSS position 10 km north for 60 s from 300 s",
              960.0, (300.0, 360.0), ("position",), _jump),
        Fault("dvl-zero", "the Doppler log reading 0 for an hour from 1800 s",
              7200.0, (1800.0, 5400.0), ("water_speed",), _dvl_zero),
    )
}

#: Default duration of a grid scenario without a fault (s).
DURATION_S = 3600.0


def compose(vessel: Vessel, suite: SuiteSpec, fault: Fault | None = None) -> Scenario:
    """The vessel's voyage and sea, the suite's sensors, the fault's damage."""
    sensors = suite.sensors()
    name = f"{vessel.name}:{suite.name}"
    description = f"{vessel.description}; {suite.description}"
    duration = DURATION_S
    if fault is not None:
        sensors = fault.apply(sensors)
        name, description, duration = f"{name}:{fault.name}", f"{description}; {fault.description}", fault.duration_s
    return Scenario(
        name, description, duration, vessel.ship, vessel.voyage(), HEADINGS[0], sensors,
        current=vessel.current, water=vessel.water, waves=vessel.waves, loading=vessel.loading,
        wave_yaw=vessel.wave_yaw,
    )


GRAMMAR = "VESSEL:SUITE[:FAULT]"


def parse(name: str) -> Scenario:
    """`VESSEL:SUITE[:FAULT]` as a scenario; ValueError naming what is unknown."""
    parts = name.split(":")
    if len(parts) not in (2, 3):
        raise ValueError(f"{name!r} is not {GRAMMAR}")
    tables = ((VESSELS, "vessel"), (SUITES, "suite"), (FAULTS, "fault"))
    picked = []
    for part, (table, what) in zip(parts, tables):
        if part not in table:
            raise ValueError(f"{name!r}: no {what} {part!r} (there are {', '.join(table)})")
        picked.append(table[part])
    return compose(*picked)


def help_text() -> str:
    """The grammar and its names, for `edged sim`'s message on an unknown scenario."""
    rows = [f"  {GRAMMAR}, e.g. tanker:fog, yacht:yacht, coaster:coastal:heading-frozen"]
    rows += [f"    vessel {n:16s} {v.description}" for n, v in VESSELS.items()]
    rows += [f"    suite  {n:16s} {s.description}" for n, s in SUITES.items()]
    rows += [f"    fault  {n:16s} {f.description}" for n, f in FAULTS.items()]
    return "\n".join(rows)
