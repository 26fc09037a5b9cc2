"""The named scenarios, as a table.

Each follows a reference scenario of ESTIMATORS.md and the paper behind it:
- `stw-*` (seed 000): a 175 m container ship at slowly varying speed with a current
  from astern (1 m/s) or rotating across the track; DVL reading 0.3 m/s high.
- `manoeuvre-williamson` (seed 002 §5.1): cruise at 11.4 kn, 35° starboard, 35° port at
  090°, 10° port at 300°, midships at 230°, slow down at 210° (pitch 0.78 → 0.33).
- `manoeuvre-zigzag-north`: a 20°/20° zigzag about north, so heading crosses 0/360°.
- `draft-harbour` (seed 003 §7.3): alongside, discharging 14 → 10 m in 0.4 m / 12 s waves.
- `draft-faulty-mark`: draft-harbour's first 20 minutes with the fore_port mark (CAN
  0x310) failing five ways, 120 s each: silent, reading 1 m high, status "fault",
  reading 45 m, losing half its frames (gaps in its counter). The other sensors read
  what they read in draft-harbour with the same seed.
- `draft-squat` (seed 003 §7.4): C_b 0.8 in a channel (blockage 0.25, so K = 2 and the
  paper's 1.6 m of squat at 10 kn), 10 kn for 50 s then up to 15 kn in 2 minutes,
  in 0.4 m / 10 s waves.
- `demo`: what `edged demo` plays: the zigzag about north with the whole reference suite
  (draft marks included, so that every estimator has its inputs) in a 0.4 m / 10 s sea.
- `faults`: the reference suite with bad checksums, garbage, impossible positions,
  truncated frames, lost samples, a GNSS outage and a 150 m position jump.
- `yacht-seaway`, `coaster-coastal`, `tanker-fog` and `fault-*` (issue 30): compositions
  of a vessel, a sensor suite and a sensor fault (`grid.py`); any other composition is
  named `VESSEL:SUITE[:FAULT]` (`lookup`).
"""

from __future__ import annotations

from dataclasses import replace

from .environment import Current, Water
from .faults import FaultSpec
from .grid import FAULTS, compose, parse
from .helm import Manoeuvre, Step, ZigZag
from .scenario import Scenario
from .ship import ShipParticulars
from .sensors import SensorSpec
from .suites import SUITES, draft_marks, echo_sounder, gyro, imu, reference_suite, stw_suite
from .truth import Loading
from .vessels import VESSELS
from .waves import JonswapWaves, RegularWaves

CONTAINER = ShipParticulars("container ship (S-175)", 175.0, 25.4, 8.5, 0.56)
CARGO = ShipParticulars("general cargo ship", 120.0, 20.0, 7.0, 0.70, nomoto_k=1.8, nomoto_t=1.8)
BULKER = ShipParticulars("bulk carrier", 225.0, 32.2, 14.0, 0.85, nomoto_k=1.6, nomoto_t=2.6)
SQUAT_SHIP = ShipParticulars("bulk carrier, channel transit", 225.0, 32.2, 10.0, 0.80, nomoto_k=1.6, nomoto_t=2.6)

#: Seed 000: U(0) = 10 m/s (19.4 kn) then the shaft speed wanders up and down.
_STW_SPEED = Manoeuvre(19.4, (
    Step(at_s=1800, speed_kn=16.0, ramp_s=600), Step(at_s=4200, speed_kn=21.0, ramp_s=900),
    Step(at_s=7200, speed_kn=17.5, ramp_s=600), Step(at_s=9000, speed_kn=19.4, ramp_s=600),
))

_WILLIAMSON = Manoeuvre(11.4, (
    Step(at_s=120, rudder_deg=35.0),
    Step(heading_deg=90, rudder_deg=-35.0),
    Step(heading_deg=300, rudder_deg=-10.0),
    Step(heading_deg=230, rudder_deg=0.0),
    Step(heading_deg=210, speed_kn=11.4 * 0.33 / 0.78, ramp_s=60.0),
))

_MANOEUVRE_SENSORS = reference_suite(7.0, drafts=False)

#: Sensor errors of the `faults` scenario, by sensor name (fields of SensorSpec).
_FAULTY: dict[str, dict] = {
    "gnss1.position": {"outages": ((200.0, 220.0),), "jumps": ((300.0, 310.0, 150.0, 0.0),)},
    "gyro.heading": {"dropout": 0.01},
    "imu.accel": {"dropout": 0.005},
}


def _faulty(s: SensorSpec) -> SensorSpec:
    extra = _FAULTY.get(s.name, {"dropout": 0.005} if s.model == "draft" else {})
    return replace(s, **extra)

#: draft-faulty-mark's fault windows on the fore_port mark: 150 s to settle first, then
#: 120 s of each fault with 90 s between them (a mark back from a fault is believed
#: again after `settle` = 60 s of agreeing with the others).
FAULT_WINDOWS = {
    "silence": (150.0, 270.0),
    "offset": (360.0, 480.0),
    "status": (570.0, 690.0),
    "range": (780.0, 900.0),
    "gaps": (990.0, 1110.0),
}


def _faulty_mark(s: SensorSpec) -> SensorSpec:
    if s.mark != "fore_port":
        return s
    w = FAULT_WINDOWS
    return replace(
        s,
        outages=(w["silence"],),
        offsets=(w["offset"] + ("draft", 1.0),),
        forced=(w["status"] + ("status", 1.0), w["range"] + ("draft", 45.0)),
        dropout_spells=(w["gaps"] + (0.5,),),
    )


_HARBOUR = Scenario(
    "draft-harbour", "Alongside, discharging 14 → 10 m, 0.4 m / 12 s waves (seed 003 §7.3)", 1800.0,
    BULKER, Manoeuvre(0.0), 0.0,
    draft_marks() + imu(50.0) + gyro(10.0) + (echo_sounder(14.0),),
    waves=RegularWaves(0.4, 12.0, from_deg=150.0), water=Water(depth=20.0),
    loading=Loading(draft_knots=((0.0, 14.0), (60.0, 14.0), (1740.0, 10.0)), trim=0.3, list=0.05,
                    deflection=0.04, roll_period=16.0),
)

SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario(
            "stw-astern-current", "STW, 1 m/s current from astern, DVL +0.3 m/s (seed 000)", 3600.0,
            CONTAINER, _STW_SPEED, 45.0, stw_suite(8.5), current=Current(set_deg=45.0, drift=1.0),
            dt=0.1, truth_rate_hz=1.0,
        ),
        Scenario(
            "stw-cross-current", "STW, 1 m/s current rotating across the track, DVL +0.3 m/s", 3600.0,
            CONTAINER, _STW_SPEED, 45.0, stw_suite(8.5),
            current=Current(set_deg=135.0 - 60.0, drift=1.0, rotation_deg_h=40.0, drift_amplitude=0.2,
                            drift_period_s=5400.0),
            dt=0.1, truth_rate_hz=1.0,
        ),
        Scenario(
            "manoeuvre-williamson", "Seed 002 §5.1 manoeuvre sequence, calm, no current", 900.0,
            CARGO, _WILLIAMSON, 20.0, _MANOEUVRE_SENSORS, water=Water(depth=80.0),
        ),
        Scenario(
            "manoeuvre-zigzag-north", "20°/20° zigzag about north: heading crosses 0/360°", 900.0,
            CARGO, ZigZag(11.4, 0.0), 0.0, _MANOEUVRE_SENSORS, water=Water(depth=80.0),
        ),
        _HARBOUR,
        replace(
            _HARBOUR, name="draft-faulty-mark", duration_s=1200.0,
            description="draft-harbour's first 20 min; the fore_port mark silent, +1 m, status fault, 45 m, "
                        "losing half its frames, 120 s each",
            sensors=tuple(_faulty_mark(s) for s in _HARBOUR.sensors),
        ),
        replace(
            _HARBOUR, name="draft-travelling", duration_s=1200.0,
            description="draft-harbour's first 20 min, the marks reading the sea at their own places: "
                        "its 12-s waves are the hull's length (225 m) and come 30° off the stern",
            marks_read_sea=True,
        ),
        replace(
            _HARBOUR, name="draft-short-crested", duration_s=1200.0,
            description="draft-harbour's first 20 min in a short-crested sea (JONSWAP Hs 1 m, Tp 10 s, "
                        "spread 30°, from abeam to port), the marks reading it at their own places",
            waves=JonswapWaves(1.0, 10.0, from_deg=270.0, spread_deg=30.0), marks_read_sea=True,
        ),
        Scenario(
            "draft-squat", "Channel transit, C_b 0.8, 10 → 15 kn in 2 min (seed 003 §7.4)", 300.0,
            SQUAT_SHIP, Manoeuvre(10.0, (Step(at_s=50.0, speed_kn=15.0, ramp_s=120.0),)), 90.0,
            reference_suite(10.0),
            waves=RegularWaves(0.4, 10.0, from_deg=270.0), water=Water(depth=14.0, channel_width=92.0),
            loading=Loading(draft_knots=((0.0, 10.0),), roll_period=18.0),
        ),
        Scenario(
            "demo", "`edged demo`: the zigzag about north with every sensor, the draft marks too, "
            "in a 0.4 m / 10 s sea", 900.0,
            CARGO, ZigZag(11.4, 0.0), 0.0, reference_suite(7.0), water=Water(depth=80.0),
            waves=RegularWaves(0.4, 10.0, from_deg=30.0), loading=Loading(draft_knots=((0.0, 7.0),), trim=0.5),
        ),
        Scenario(
            "faults", "Reference suite with injected damage, lost samples and a position jump", 600.0,
            CARGO, ZigZag(11.4, 45.0, rudder_deg=10.0, heading_deg=10.0), 45.0,
            tuple(_faulty(s) for s in reference_suite(7.0)), water=Water(depth=80.0),
            waves=JonswapWaves(1.5, 8.0, from_deg=10.0),
            loading=Loading(draft_knots=((0.0, 7.0),)),
            faults=FaultSpec(bad_checksum=0.003, garbage=0.002, impossible=0.01, bad_length=0.0005),
        ),
    )
}

#: Named compositions of the generalisation grid (`grid.py`, issue 30): one vessel per
#: suite it is typical of, and each fault of issue 30 on the coaster (the accelerometer
#: fault with its IMU at 50 Hz, the others on the lighter coastal suite).
_COMPOSED: dict[str, tuple[str, str, str | None]] = {
    "yacht-seaway": ("yacht", "yacht", None),
    "coaster-coastal": ("coaster", "coastal", None),
    "tanker-fog": ("tanker", "fog", None),
    "fault-accel-saturated": ("coaster", "reference", "accel-saturated"),
    "fault-gap-6h": ("coaster", "coastal", "gap-6h"),
    "fault-heading-frozen": ("coaster", "coastal", "heading-frozen"),
    "fault-position-jump": ("coaster", "coastal", "position-jump"),
    "fault-dvl-zero": ("coaster", "coastal", "dvl-zero"),
}
for _name, (_v, _s, _f) in _COMPOSED.items():
    _sc = compose(VESSELS[_v], SUITES[_s], FAULTS[_f] if _f else None)
    SCENARIOS[_name] = replace(_sc, name=_name, description=f"{_sc.name}: {_sc.description}")


def lookup(name: str) -> Scenario:
    """A named scenario, or a composition `VESSEL:SUITE[:FAULT]` (`grid.parse`);
    ValueError saying what is unknown."""
    if name in SCENARIOS:
        return SCENARIOS[name]
    if ":" in name:
        return parse(name)
    raise ValueError(f"unknown scenario {name!r}")
