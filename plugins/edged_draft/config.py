"""Configuration of the draft estimator (`[estimators.<name>] type = "draft"`).

The defaults are physics that hold for any displacement ship and the sensors of seed
003 (pressure or radar draft sensors at 100 Hz, σ 0.1 m); the vessel's own figures
(where the marks are, her beam, block coefficient, TPC) come from her documents and are
null until given, and the values that need them are null too.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from edged.plugin import EstimatorConfig


class DraftConfig(EstimatorConfig):
    #: `adaptive` (default) or the paper's three-state filter (`paper`).
    mode: Literal["adaptive", "paper"] = "adaptive"
    #: Published at this rate (estimates per second of data time).
    publish_rate: float = Field(1.0, ge=0.0, le=1000.0)
    #: In a process of its own by default: six marks at 100 Hz are 600 filter steps a
    #: second, which in the loop would take a core's worth of the inputs' time in a
    #: fast replay (`tests/bench/bench_draft.py`: 1 h replayed in about half the time).
    worker: Literal["loop", "process"] = "process"

    # Sensors.
    #: 1-σ of one reading, m (the start: each mark's own is then learned).
    sensor_sigma: float = Field(0.1, gt=0.0, le=10.0)
    #: Learn each mark's noise from its innovations.
    adapt_r: bool = True
    #: A reading outside [min_draft, max_draft] m is impossible (counted `range`). Not
    #: 0: a mark reading 0 is a sensor in air or unpowered, not a hull afloat.
    min_draft: float = Field(0.01, ge=0.0, le=70.0)
    max_draft: float = Field(30.0, gt=0.0, le=70.0)
    #: A mark silent this long (s of data time) is out until it speaks again.
    silence: float = Field(1.0, gt=0.0, le=3600.0)
    #: A mark losing more than this share of its readings (over 10 s) is out until it
    #: loses fewer (gaps in its rhythm, as the CAN counter would show).
    max_lost: float = Field(0.2, gt=0.0, le=1.0)
    #: χ² (1 dof) gate on a reading's innovation; 15.1 is the 99.99 % point.
    gate: float = Field(15.1, gt=0.0)
    #: After this many gated readings in a row the mark has jumped: it is out, and its
    #: filter starts again from its readings.
    jump_after: int = Field(50, ge=1, le=100_000)
    #: A mark that jumped (or came back after a fault) is back in the derived values
    #: when, after this many seconds, its mean agrees with what its partner and the
    #: list at the other stations say, within `agree` m.
    settle: float = Field(60.0, ge=0.0, le=86_400.0)
    agree: float = Field(0.1, gt=0.0, le=10.0)

    # The level (wave-free draft): a random walk on its acceleration.
    #: Spectral density of the level's jerk, m²/s⁵. Cargo work moves the draft by mm/s
    #: and changes that rate over minutes (squat, faster, follows the speed instead).
    #: Its bandwidth, (q_jerk/(R·dt))^(1/6), is 0.07 rad/s for σ 0.1 m at 100 Hz: a
    #: period of a minute and a half, well below the longest seas' (25 s; following
    #: seas at speed meet the ship at 20 s) and above any cargo plan's.
    q_jerk: float = Field(1e-11, gt=0.0, le=1.0)
    #: Squat: the level follows κ·STW² with κ learned (`waves.py`), from `stw_from`.
    squat_from_speed: bool = True
    #: κ's random walk, (m per (m/s)²)² per s: it may drift by 0.008 (a quarter of a
    #: typical 0.03) in ten minutes, as the depth and the channel change under a
    #: transiting ship; faster, and the STW estimate's scatter wears κ down.
    q_squat: float = Field(1e-7, ge=0.0, le=1.0)
    #: Seconds of STW estimates whose least-squares line is the speed the squat follows.
    #: Longer smooths the scatter, but lags where the speed turns (a line through a
    #: kink): 5 s holds both to about a centimetre of draft at 15 kn.
    speed_window: float = Field(5.0, ge=0.0, le=600.0)

    # Adaptive mode: the wave bank.
    #: Shortest and longest encounter periods the bank spans, s.
    wave_period_min: float = Field(3.0, gt=0.5, le=60.0)
    wave_period_max: float = Field(25.0, gt=1.0, le=120.0)
    #: Resonators in the bank, log-spaced in frequency.
    resonators: int = Field(12, ge=1, le=64)
    #: Damping ratio of each resonator: its bandwidth, relative to its frequency, is 2ζ.
    #: 0.006: each resonator's phase and amplitude follow a sea that is a spectrum,
    #: not one sine, and an encounter frequency that moves with the speed (a pure
    #: sine would want less, and passes a little more noise into the draft with it).
    damping: float = Field(0.006, gt=0.0, lt=1.0)
    #: 1-σ of each resonator's motion before the sea says otherwise, m.
    wave_sigma: float = Field(0.3, gt=0.0, le=20.0)
    #: Seconds over which a mark's wave amplitude is measured (√2 × the RMS).
    amplitude_window: float = Field(60.0, gt=0.0, le=3600.0)

    #: The instantaneous drafts of the good marks fitted to one rigid hull's heave,
    #: pitch and roll (`derived.rigid_waves`).
    rigid_hull: bool = True

    # Paper mode (seed 003 §7): ω_e and ε given, q_v = q_m = 1e-3.
    omega_e: float = Field(2.0 * 3.141592653589793 / 12.0, gt=0.0, le=20.0)
    epsilon: float = Field(0.0, ge=-7.0, le=7.0)
    q_v: float = Field(1e-3, ge=0.0, le=1e3)
    q_m: float = Field(1e-3, ge=0.0, le=1e3)

    # The vessel.
    #: Distance between the fore and aft marks, m (the draft line through them gives
    #: the draft anywhere along the hull: at the echo sounder, at the perpendiculars).
    mark_spacing: float | None = Field(None, gt=0.0, le=600.0)
    #: Beam, m: heel = atan(list / beam).
    beam: float | None = Field(None, gt=0.0, le=100.0)
    #: Block coefficient for squat; null: no squat.
    block_coefficient: float | None = Field(None, gt=0.3, le=1.0)
    #: Blockage S = b·T / (W·h) of the channel for Barrass's K = 5.74·S^0.76; null: open
    #: water (K = 1).
    blockage: float | None = Field(None, gt=0.0, le=1.0)
    #: The echo sounder: its position ahead of midships (m) and height above the keel (m).
    transducer_x: float = Field(0.0, ge=-300.0, le=300.0)
    transducer_height: float = Field(0.0, ge=-10.0, le=30.0)
    #: Depth readings older than this (s) give no under-keel clearance.
    depth_max_age: float = Field(10.0, gt=0.0, le=3600.0)
    #: Seconds over which the soundings' water depth is averaged (the sounder's noise;
    #: a transiting ship's seabed changes along the track, so not much longer).
    depth_window: float = Field(10.0, gt=0.0, le=3600.0)
    #: The estimator instance whose STW gives the squat (null: none, no squat).
    stw_from: str | None = "stw"
    #: STW estimates older than this (s) give no squat.
    stw_max_age: float = Field(10.0, gt=0.0, le=3600.0)

    # Cargo.
    #: Tonnes per centimetre immersion, or a hydrostatic table [[mean draft m,
    #: displacement t], ...] in increasing draft; neither: no displacement values.
    tpc: float | None = Field(None, gt=0.0, le=10_000.0)
    hydrostatics: list[tuple[float, float]] | None = None
    #: The reference moment: seconds after the first published mean draft (the moment
    #: cargo work is measured from).
    reference_after: float = Field(60.0, ge=0.0, le=86_400.0)
    #: Seconds of mean draft whose slope is the cargo rate.
    cargo_window: float = Field(300.0, ge=10.0, le=86_400.0)

    @field_validator("hydrostatics")
    @classmethod
    def _table(cls, v: list[tuple[float, float]] | None) -> list[tuple[float, float]] | None:
        if v is None:
            return v
        if len(v) < 2 or len(v) > 1000:
            raise ValueError("between 2 and 1000 rows of [draft m, displacement t]")
        for (d0, w0), (d1, w1) in zip(v, v[1:]):
            if not (d1 > d0 and w1 > w0):
                raise ValueError("drafts and displacements must both increase down the table")
        return v

    @field_validator("wave_period_max")
    @classmethod
    def _band(cls, v: float, info) -> float:  # noqa: ANN001 (pydantic's)
        lo = info.data.get("wave_period_min")
        if lo is not None and v <= lo:
            raise ValueError("wave_period_max must be above wave_period_min")
        return v
