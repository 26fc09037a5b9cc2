"""Configuration of the STW estimator (`[estimators.<name>] type = "stw"`).

Defaults are the sensors of seed 000's Table 1 (GNSS position σ 2.5 m, SOG σ 0.065 m/s,
acceleration σ 0.05 m/s², current forecast σ 0.2 m/s) and physics that holds for any
displacement vessel; nothing here is fitted to one simulator.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from edged.plugin import EstimatorConfig


class ConstantCurrent(BaseModel):
    """A current known from the chart or the pilot book, when no forecast arrives."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    #: Direction the current flows toward, degrees true.
    set_deg: float = Field(ge=0.0, le=360.0)
    #: Speed, m/s.
    drift: float = Field(ge=0.0, le=10.0)
    #: 1-σ of each component, m/s: how far the real current may be from this.
    sigma: float = Field(0.5, gt=0.0, le=10.0)


class StwConfig(EstimatorConfig):
    #: `vector` (default) or the paper's four-state filter (`paper`).
    mode: Literal["vector", "paper"] = "vector"
    #: Published at this rate (estimates per second of data time).
    publish_rate: float = Field(1.0, ge=0.0, le=1000.0)
    #: In a process of its own by default: the filter then runs beside the inputs and
    #: the recorder on another core instead of taking the event loop's time (issue 34:
    #: a replay of the reference load runs 16 % faster with stw and manoeuvre there).
    worker: Literal["loop", "process"] = "process"
    #: GNSS at 30 s and forecasts at 20 min are normal: stale only after a minute.
    stale_after: float = Field(60.0, ge=0.0, le=86_400.0)

    # Sensor noise (1-σ), SI units.
    position_sigma: float = Field(2.5, gt=0.0, le=1000.0)
    sog_sigma: float = Field(0.065, gt=0.0, le=10.0)
    accel_sigma: float = Field(0.05, gt=0.0, le=10.0)
    forecast_sigma: float = Field(0.2, gt=0.0, le=10.0)
    #: White error of the (smoothed) heading, and its persistent misalignment
    #: (compass deviation, mounting), degrees.
    heading_sigma_deg: float = Field(0.5, gt=0.0, le=30.0)
    heading_bias_deg: float = Field(0.5, ge=0.0, le=30.0)
    #: Seconds over which the heading is averaged for heading − course (heading.py).
    heading_average: float = Field(10.0, gt=0.0, le=600.0)
    dvl_sigma: float = Field(0.1, gt=0.0, le=10.0)

    # Vessel motion (vector mode).
    #: Spectral density of the jerk (m²/s⁵): how quickly the acceleration may change.
    jerk_density: float = Field(1e-6, gt=0.0, le=1.0)
    #: Seconds of IMU samples averaged into one acceleration update.
    accel_average: float = Field(1.0, ge=0.0, le=60.0)
    #: 1-σ of the sway through the water on a straight course (leeway from wind, a
    #: compass misalignment), m/s, and how long it persists, s.
    leeway_sigma: float = Field(0.1, gt=0.0, le=5.0)
    leeway_time: float = Field(600.0, gt=0.0, le=86_400.0)
    #: Above this rate of turn (deg/s) the hull sways: heading − course says nothing
    #: about the current, and the log is not fitted.
    turn_rate_max_deg: float = Field(0.3, gt=0.0, le=30.0)
    #: Below this speed over ground (m/s) heading − course is not used either.
    min_speed: float = Field(1.0, ge=0.0, le=20.0)
    #: After a turn the hull goes on swaying (its drift angle decays over tens of
    #: seconds): heading − course and the log wait this long (s) after the last turn.
    turn_settle: float = Field(60.0, ge=0.0, le=3600.0)

    # Start-up and gaps.
    #: No GNSS for longer than this (s of data time): the filter restarts from the next
    #: measurements instead of predicting across the gap (the current seen before the
    #: gap comes back as a forecast if it is not older than `forecast_max_age`).
    reset_after: float = Field(120.0, gt=0.0, le=86_400.0)
    #: Nothing is published while the ground velocity's 1-σ exceeds this (m/s: a
    #: filter started from positions alone has 10 m/s), and estimates are marked
    #: `converging` until it is below `converged_std`.
    publish_max_std: float = Field(1.0, gt=0.0, le=100.0)
    converged_std: float = Field(0.3, gt=0.0, le=100.0)

    # Current (vector mode): three hypotheses mixed by how well each predicts the
    # forecasts and heading − course (interacting multiple models, current.py).
    #: Random walk of a steady current, m²/s³ (≈ 0.006 m/s in an hour).
    current_steady_q: float = Field(1e-8, gt=0.0, le=1.0)
    #: Random walk of the rate of change of a slowly drifting current, m²/s⁵.
    current_slow_q: float = Field(1e-13, gt=0.0, le=1.0)
    #: The same for a current that turns within the hour (a rotary tidal stream).
    current_fast_q: float = Field(3e-12, gt=0.0, le=1.0)
    #: 1-σ of the current's rate of change before any forecast, m/s² (0.36 m/s per hour).
    current_rate_sigma: float = Field(1e-4, gt=0.0, le=1.0)
    #: Probability that the current switches hypothesis between two forecasts.
    current_switch: float = Field(0.03, gt=0.0, lt=0.5)
    #: 1-σ of the current before any forecast, m/s (no forecast: no current assumed,
    #: with this uncertainty).
    current_prior_sigma: float = Field(1.0, gt=0.0, le=10.0)
    #: The current's 1-σ never grows beyond this, m/s: an unobserved current is still
    #: one of the sea's (its spread does not grow with time), so by default the prior's.
    #: 2.0 once let the current's rate, integrated over hours without a forecast, grow
    #: σ_STW to 1.9 m/s on a 4-h yacht log (plaka). Raise it in strong tidal streams.
    current_sigma_max: float = Field(1.0, gt=0.0, le=20.0)

    #: Forecasts whose innovations adapt the current's process noise (0: no adaptation)
    #: and the largest factor the adaptation may apply.
    forecast_adapt_window: int = Field(4, ge=0, le=100)
    forecast_adapt_limit: float = Field(100.0, ge=1.0, le=1e6)

    # Forecasts.
    #: Forecast errors stay correlated this long (s): forecasts arriving more often
    #: count for less, so a provider re-sending the same field every second does not
    #: make the filter overconfident.
    forecast_interval: float = Field(1200.0, gt=0.0, le=86_400.0)
    #: A forecast whose own time (t_src) is older than this (s) is not used.
    forecast_max_age: float = Field(3 * 3600.0, gt=0.0, le=30 * 86_400.0)
    #: Mahalanobis gate (χ², 2 dof) for forecasts; 13.8 is the 99.9 % point.
    forecast_gate: float = Field(13.8, gt=0.0)
    #: A configured current, used as a forecast every `forecast_interval`.
    current: ConstantCurrent | None = None

    # GNSS gates.
    #: Mahalanobis gate (χ², 2 dof) for positions and velocities; 18.4 is 99.99 %.
    gnss_gate: float = Field(18.4, gt=0.0)
    #: After this many rejected fixes in a row the filter trusts the GNSS again (reset).
    gnss_reset_after: int = Field(10, ge=1, le=10_000)
    #: Speeds over ground above this (m/s) are impossible for the vessel.
    max_sog: float = Field(30.0, gt=0.0, le=200.0)

    # The log under test.
    #: Warn when the log's offset exceeds this (m/s) with 95 % confidence.
    dvl_tolerance: float = Field(0.2, gt=0.0, le=10.0)
    #: `dvl_bias` is published (not null) once its 1-σ is below this, m/s.
    dvl_observable_std: float = Field(0.15, gt=0.0, le=10.0)
    #: Warn when the log's scale error exceeds this (fraction) with 95 % confidence.
    dvl_scale_tolerance: float = Field(0.03, gt=0.0, le=1.0)
    #: Fit the log's scale error k as well as its offset b. Off by default: k is
    #: separable from a changing current only when the speed changes much faster than
    #: the current does; on a 3-hour passage with 10-minute speed changes in a turning
    #: tidal stream the fit read the current's change as a 2–4 % scale error. Turn it on
    #: for long logs with many speed changes (trials, port approaches).
    dvl_fit_scale: bool = False
    #: 1-σ of the log's scale error before any fit (fraction).
    dvl_scale_prior: float = Field(0.05, gt=0.0, le=1.0)

    # Paper mode.
    #: The paper's sample time T (s): GNSS and acceleration every 30 s.
    paper_period: float = Field(30.0, gt=0.0, le=3600.0)
    #: The paper's tuning knob σ_c: current random walk per sample time, m/s.
    paper_sigma_c: float = Field(0.01, gt=0.0, le=10.0)
