"""The `stw` estimate kind: the fields an STW estimate has (DESIGN §6).

Declared here, with the estimator, and registered with the core through the entry
point `edged.estimate_kinds: stw` (the MCAP schema, `edged score` and the docs read it
from `edged.estimates.ESTIMATE_KINDS`).
"""

from __future__ import annotations

from edged.estimates import OBJECT, STRING, EstimateKind, est_field, nullable_field

STW = EstimateKind(
    "stw",
    "Speed through water from GNSS, IMU and current, never from the Doppler log (seed 000).",
    (
        est_field("stw", "m/s", "speed through water (magnitude)", std="stw_std", truth="stw",
                  baseline=("water_speed", "stw_long"), derived=("naive_stw",)),
        est_field("stw_std", "m/s", "1-σ of stw"),
        est_field("sog", "m/s", "speed over ground (filtered)", truth="sog", baseline=("velocity_ground", "sog")),
        nullable_field("current", "m/s", "current speed (drift) used by the filter"),
        nullable_field("distance", "m", "distance travelled over ground since start"),
        nullable_field("dvl_stw", "m/s", "the Doppler log's reading, kept for comparison only"),
        nullable_field("stw_long", "m/s", "along-ship speed through water (null in paper mode)", truth="stw_long",
                       baseline=("water_speed", "stw_long")),
        nullable_field("stw_trans", "m/s", "athwartship speed through water, + to starboard (null in paper mode)",
                       truth="stw_trans"),
        est_field("mode", "name", "paper or vector", type=STRING),
        nullable_field("current_set", "rad", "direction the current flows toward", angle=True, truth="current_set"),
        nullable_field("current_along", "m/s", "current along the track, + following", truth="current_along"),
        nullable_field("dvl_bias", "m/s", "the log's offset b in dvl = (1 + k)·stw + b"),
        nullable_field("dvl_scale", "1", "the log's scale 1 + k (1 = no error)"),
        est_field("dvl_std", "object", "1-σ of dvl_bias and dvl_scale ({bias, scale}); null without a log",
                  type=OBJECT, nullable=True),
    ),
)
