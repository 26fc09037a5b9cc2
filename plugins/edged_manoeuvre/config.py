"""Configuration of the manoeuvring-state estimator (`[estimators.<name>] type = "manoeuvre"`).

Two sets of defaults, chosen by `mode`:
- `tuned` (default): noise for the sensors ships carry (GNSS σ 1.5 m, gyro 0.2°,
  rate of turn 0.05°/s, MEMS accelerometers 0.03 m/s² with a bias) and process noise
  from what a displacement hull can do (a yaw acceleration of about 3e-4 rad/s² in a
  second, a jerk of about 0.01 m/s³), then learned or adapted online: each sensor's
  variance from its innovations, the process noise when the NIS leaves its χ² band,
  the accelerometers' biases as states. Nothing here is fitted to one simulator.
- `paper`: seed 002's Table 3 exactly (Q, R, δt = 0.005 s), its two-point
  differencing start and P0 of eqs. (20)–(22), nothing adapted, no biases: the paper's
  filter, for comparison. Angles are wrapped in both (that fix is not optional).
Every value can be set; an unset one takes its mode's default.
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, ValidationInfo, field_validator

from edged.plugin import EstimatorConfig

DEG = math.pi / 180.0

#: Seed 002, Table 3 (Q in the CTRA's state order; R for z = [p_n, p_e, ψ, r, a_u, a_v]).
PAPER_Q = (1e-1, 1e-1, 1e-3, 1e-3, 1e-5, 1e-5, 1e-1 * DEG, 1e-5 * DEG)
PAPER_R = {"position": 1.0, "heading": 0.5 * DEG, "yaw_rate": 1e-3 * DEG, "accel": 0.01}

#: mode -> default of every field left unset (None).
DEFAULTS = {
    "tuned": {
        "substep": 0.05, "position_sigma": 1.5, "heading_sigma_deg": 0.2, "yaw_rate_sigma_deg": 0.05,
        "accel_sigma": 0.03, "q_position": 1e-4, "q_velocity": 1e-6, "q_heading": 1e-8,
        "q_yaw_accel": 1e-7, "q_jerk": 1e-4, "q_bias": 1e-8, "adapt_q": True, "adapt_r": True,
        "yaw_accel_tau": 2.0, "q_yaw_jerk": 1e-6,
        "gate": True, "imu_bias": True, "init_window": 3.0, "max_rate": 10.0, "use_sog": True,
        "velocity_sigma": 0.1,
    },
    "paper": {
        "substep": 0.005, "position_sigma": PAPER_R["position"], "heading_sigma_deg": 0.5,
        "yaw_rate_sigma_deg": 1e-3, "accel_sigma": PAPER_R["accel"],
        "q_position": PAPER_Q[0], "q_velocity": PAPER_Q[2], "q_heading": PAPER_Q[4],
        "q_yaw_accel": PAPER_Q[5], "q_jerk": PAPER_Q[6], "q_jerk_v": PAPER_Q[7], "q_bias": 1e-8,
        "yaw_accel_tau": 0.0, "q_yaw_jerk": 0.0,
        "adapt_q": False, "adapt_r": False, "gate": False, "imu_bias": False, "init_window": 0.0,
        "max_rate": 0.0, "use_sog": False, "velocity_sigma": 0.1,
    },
}


class ManoeuvreConfig(EstimatorConfig):
    #: `tuned` (default) or the paper's filter as published (seed 002); sets the
    #: defaults of every key shown "(by mode)".
    mode: Literal["tuned", "paper"] = "tuned"
    #: Motion model: constant turn rate and acceleration, or the curvilinear one.
    model: Literal["ctra", "cmm"] = "ctra"
    #: Extended, unscented or ensemble Kalman filter.
    filter: Literal["ekf", "ukf", "enkf"] = "ekf"
    #: In a process of its own by default (every filter): its updates at the IMU's
    #: 50 Hz then run beside the inputs on another core instead of taking the event
    #: loop's time (issue 34: a replay of the reference load 16 % faster).
    worker: Literal["loop", "process"] = "process"
    #: EnKF: members, the random generator's seed, multiplicative inflation per update.
    members: int = Field(100, ge=3, le=100_000)
    seed: int = Field(0, ge=0)
    inflation: float = Field(1.0, ge=1.0, le=2.0)
    #: Estimates per second of data time, and when they are stale (GNSS lost).
    publish_rate: float = Field(10.0, ge=0.0, le=1000.0)
    stale_after: float = Field(3.0, ge=0.0, le=86_400.0)
    #: Prediction horizons (s) and the time constant (s) of the accelerations' decay in it.
    horizons: list[float] = Field(default_factory=lambda: [10.0, 30.0, 60.0, 120.0])
    accel_decay: float = Field(30.0, gt=0.0, le=3600.0)
    #: The prediction is made afresh this many times a second of data time (0: with
    #: every estimate); in between each estimate carries the last one, its `dt`
    #: counted from the estimate's own time.
    predict_rate: float = Field(1.0, ge=0.0, le=1000.0)
    #: The predictions of the last `ellipse_window` seconds that have come due size
    #: each horizon's ellipse, so that its `ellipse_sigmas` multiple held the GNSS
    #: fixes at the Gaussian rate (2σ: 86.5 %; `calibrate.py`); 0 s: the model's
    #: covariance as it is.
    ellipse_window: float = Field(600.0, ge=0.0, le=86_400.0)
    ellipse_sigmas: float = Field(2.0, ge=0.5, le=4.0)
    #: Largest Runge–Kutta sub-step, s.
    substep: float | None = Field(None, gt=0.0, le=1.0, validate_default=True)

    # Sensor noise (1-σ), the starting values when adapted.
    position_sigma: float | None = Field(None, gt=0.0, le=1000.0, validate_default=True)
    heading_sigma_deg: float | None = Field(None, gt=0.0, le=30.0, validate_default=True)
    yaw_rate_sigma_deg: float | None = Field(None, gt=0.0, le=30.0, validate_default=True)
    accel_sigma: float | None = Field(None, gt=0.0, le=10.0, validate_default=True)
    #: The GNSS's own velocity (SOG/COG, its Doppler), m/s per axis.
    velocity_sigma: float | None = Field(None, gt=0.0, le=10.0, validate_default=True)
    #: Update with the GNSS's SOG/COG as a velocity over ground (tuned: yes; seed 002
    #: has positions only). A receiver's Doppler velocity is good to a few cm/s; without
    #: it, a vessel with no IMU knows her velocity only by differencing fixes, and a
    #: 1 Hz compass that swings with the waves turns it at every update.
    use_sog: bool | None = Field(None, validate_default=True)

    # Process noise: spectral densities of the white noise on each state's derivative.
    q_position: float | None = Field(None, ge=0.0, le=1e3, validate_default=True)  # m²/s
    q_velocity: float | None = Field(None, ge=0.0, le=1e3, validate_default=True)  # m²/s³
    q_heading: float | None = Field(None, ge=0.0, le=1.0, validate_default=True)  # rad²/s
    q_yaw_accel: float | None = Field(None, ge=0.0, le=1.0, validate_default=True)  # rad²/s³
    q_jerk: float | None = Field(None, ge=0.0, le=1e3, validate_default=True)  # m²/s⁵ (a_u; a_t)
    #: The sway acceleration's (a_v; a_n), when it differs (the paper's Table 3 does).
    q_jerk_v: float | None = None
    q_bias: float | None = Field(None, ge=0.0, le=1.0, validate_default=True)  # m²/s⁵
    #: The yaw acceleration as a state (`model.YawAcceleration`): its correlation time
    #: τ (s; 0: no such state, the paper's ṙ = 0) and the density of the white noise
    #: driving it (rad²/s⁵; the NIS adaptation scales it from a launch to a tanker:
    #: wave yaw of ±5° at 4 s is ~0.04, a tanker's rudder order ~1e-7).
    yaw_accel_tau: float | None = Field(None, ge=0.0, le=60.0, validate_default=True)
    q_yaw_jerk: float | None = Field(None, ge=0.0, le=10.0, validate_default=True)  # rad²/s⁵

    #: Adapt Q and R from the innovations (NIS), gate outliers, estimate the IMU's bias.
    adapt_q: bool | None = Field(None, validate_default=True)
    adapt_r: bool | None = Field(None, validate_default=True)
    gate: bool | None = Field(None, validate_default=True)
    imu_bias: bool | None = Field(None, validate_default=True)
    #: Seconds of fixes fitted by a straight line for the starting velocity (0: the
    #: paper's two-point differencing of the first two fixes). 3 s: a 10 Hz receiver's
    #: 1.5 m of noise gives a 1-s line's slope a σ of 1.3 m/s (2.5 kn at a berth), a
    #: 3-s line's 0.25; a slower receiver starts from its last three fixes.
    init_window: float | None = Field(None, ge=0.0, le=60.0, validate_default=True)

    #: A sensor faster than this (Hz) is averaged in blocks to it before the update
    #: (a 50 Hz IMU: five samples a measurement); 0 updates with every sample.
    max_rate: float | None = Field(None, ge=0.0, le=1000.0, validate_default=True)
    #: A data-time gap longer than this (s) in every input starts the filter again from
    #: the measurements after it instead of integrating the model across it: nothing a
    #: kinematic model predicts minutes ahead is an estimate, and integrating a gap
    #: between two logs of different days would take hours of Runge–Kutta sub-steps.
    #: It also bounds the work of one step (at most reset_after / substep sub-steps).
    reset_after: float = Field(120.0, gt=0.0, le=3600.0)
    #: After a start, an estimate is `converging` until this many position fixes and
    #: as many headings have been taken in (a start's σ is honest, but wide).
    converge_updates: int = Field(5, ge=0, le=1000)
    #: Plane origin moved to the estimate when the vessel is this far from it, m.
    origin_radius: float = Field(5000.0, ge=100.0, le=100_000.0)
    #: Take the current for the drift through the water from this estimator's
    #: `est/<name>` (an `stw` instance), or from `current` measurements when None.
    current_from: str | None = None

    @field_validator(
        "substep", "position_sigma", "heading_sigma_deg", "yaw_rate_sigma_deg", "accel_sigma", "velocity_sigma",
        "use_sog", "q_position",
        "q_velocity", "q_heading", "q_yaw_accel", "q_jerk", "q_bias", "yaw_accel_tau", "q_yaw_jerk", "adapt_q", "adapt_r", "gate", "imu_bias",
        "init_window", "max_rate",
    )
    @classmethod
    def _mode_default(cls, v: object, info: ValidationInfo) -> object:
        if v is not None:
            return v
        return DEFAULTS[info.data.get("mode", "tuned")][info.field_name]  # type: ignore[index]

    @field_validator("horizons")
    @classmethod
    def _horizons(cls, v: list[float]) -> list[float]:
        if len(v) > 20 or any(not (0.0 < h <= 3600.0) for h in v):
            raise ValueError("at most 20 horizons, each in (0, 3600] s")
        return sorted(v)

    def jerk_v(self) -> float:
        if self.q_jerk_v is not None:
            return self.q_jerk_v
        return DEFAULTS[self.mode].get("q_jerk_v", self.q_jerk)  # type: ignore[return-value]
