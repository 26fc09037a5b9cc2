"""The `draft` estimate kind: the fields a draft estimate has, and the six marks
(DESIGN §5, §6).

Declared here, with the estimator, and registered with the core through the entry
point `edged.estimate_kinds: draft`.
"""

from __future__ import annotations

from edged.estimates import ARRAY, BOOL, OBJECT, EstimateKind, est_field, nullable_field

#: The six draft marks (DESIGN §5, CAN ids 0x310..0x315 in this order).
DRAFT_MARKS: tuple[str, ...] = ("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd")

DRAFT = EstimateKind(
    "draft",
    "Draft at six marks with trim, list, deflection, squat and under-keel clearance (seed 003).",
    (
        est_field("marks", "object", "per mark: draft, mean, rate, amplitude, std, ok", type=OBJECT),
        nullable_field("mean_draft", "m", "mean of the marks' wave-free means", std="mean_draft_std",
                       truth="mean_draft"),
        nullable_field("mean_draft_std", "m", "1-σ of mean_draft"),
        est_field("filled", "list", "marks out whose mean the derived values take from their partner and the list",
                  type=ARRAY),
        nullable_field("trim", "m", "aft − fore, + by the stern", truth="trim"),
        nullable_field("list", "m", "port − starboard", truth="list"),
        nullable_field("heel", "rad", "heel angle (when the beam is configured)"),
        nullable_field("deflection", "m", "mid − mean(fore, aft), + sagging", truth="deflection"),
        nullable_field("squat", "m", "Barrass squat from the STW estimate", std="squat_std", truth="squat"),
        nullable_field("squat_std", "m", "1-σ of squat, from the STW estimate's"),
        nullable_field("ukc", "m", "under-keel clearance (when depth is measured)", truth="ukc"),
        nullable_field("displacement_change", "t", "since the reference moment (null without TPC)",
                       std="displacement_change_std"),
        nullable_field("displacement_change_std", "t", "1-σ of displacement_change"),
        nullable_field("cargo_rate", "t/h", "rate of displacement change (null without TPC)", std="cargo_rate_std"),
        nullable_field("cargo_rate_std", "t/h", "1-σ of cargo_rate"),
    ),
    mark_fields=(
        nullable_field("draft", "m", "instantaneous filtered draft", std="std", truth="draft_{mark}",
                       baseline=("draft", "draft")),
        nullable_field("mean", "m", "draft with the wave motion removed", truth="draft_{mark}_mean",
                       baseline=("draft", "draft")),
        nullable_field("rate", "m/s", "rate of change of the draft"),
        nullable_field("amplitude", "m", "amplitude of the wave-induced oscillation"),
        nullable_field("std", "m", "1-σ of draft"),
        est_field("ok", "bool", "false when the mark's sensor is excluded (fault, silence, jump)", type=BOOL),
    ),
    marks=DRAFT_MARKS,
)
