"""The `manoeuvre` estimate kind: the fields a manoeuvring-state estimate has (DESIGN §6).

Declared here, with the estimator, and registered with the core through the entry
point `edged.estimate_kinds: manoeuvre`.
"""

from __future__ import annotations

from edged.estimates import ARRAY, OBJECT, STRING, EstimateKind, est_field, nullable_field

MANOEUVRE = EstimateKind(
    "manoeuvre",
    "Manoeuvring state: kinematic CTRA/CMM with EKF/UKF/EnKF (seeds 002, 001, 004).",
    (
        est_field("lat", "deg", "latitude (WGS-84)"),
        est_field("lon", "deg", "longitude (WGS-84)"),
        est_field("x", "m", "north in the estimator's own tangent plane (scored through lat, lon)", std="std.x"),
        est_field("y", "m", "east in the estimator's own tangent plane (scored through lat, lon)", std="std.y"),
        est_field("u", "m/s", "surge speed (body x)", std="std.u", truth="u"),
        est_field("v", "m/s", "sway speed (body y, + starboard)", std="std.v", truth="v"),
        est_field("r", "rad/s", "yaw rate, + to starboard", std="std.r", truth="r", baseline=("yaw_rate", "r")),
        est_field("heading", "rad", "true heading", angle=True, std="std.heading", truth="heading",
                  baseline=("heading", "heading")),
        est_field("a_u", "m/s^2", "surge acceleration", std="std.a_u", truth="a_u"),
        est_field("a_v", "m/s^2", "sway acceleration", std="std.a_v", truth="a_v"),
        est_field("sog", "m/s", "speed over ground", truth="sog", baseline=("velocity_ground", "sog")),
        est_field("cog", "rad", "course over ground", angle=True, truth="cog", baseline=("velocity_ground", "cog")),
        est_field("drift_angle", "rad", "atan2(v, u): drift over ground", angle=True, truth="drift_angle"),
        nullable_field("drift_angle_water", "rad", "drift through the water (null without a known current)"),
        nullable_field("nis", "1", "normalised innovation squared of the latest update"),
        nullable_field("rcond", "1", "reciprocal condition number of that update's innovation covariance (eq. 23)"),
        est_field("q_scale", "object", "process-noise scale of the NIS adaptation per group (yaw, translation)",
                  type=OBJECT),
        est_field("mode", "name", "tuned or paper", type=STRING),
        nullable_field("accel_bias", "m/s^2", "accelerometer biases [b_x, b_y] (null without bias states)", type=ARRAY),
        est_field("model", "name", "ctra or cmm", type=STRING),
        est_field("filter", "name", "ekf, ukf or enkf", type=STRING),
        est_field("std", "object", "1-σ per state, keyed by field name", type=OBJECT),
        est_field("predicted", "list", "[{dt, lat, lon, heading, std_major, std_minor, std_angle}] per horizon",
                  type=ARRAY),
    ),
)
