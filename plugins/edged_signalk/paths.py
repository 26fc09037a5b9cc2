"""Where each fused value goes in Signal K: the paths, in SI units as Signal K wants.

The paths are the Signal K specification's (signalk-schema 1.8, the version
signalk-server 2.x ships) where it names the value, and `edged.*` where it names
none. Each choice, with its reason:

- `navigation.speedThroughWater` (m/s): the spec's STW, the estimate's `stw`.
- `navigation.speedThroughWaterLongitudinal`, `...Transverse` (m/s): the spec's
  along- and athwartship STW (`stw_long`, `stw_trans`; transverse + to starboard).
  The spec has no `speedThroughWaterReferenceType`; none is sent.
- `environment.current` ({setTrue rad, drift m/s}): the spec's one object for the
  current; `setMagnetic` is left out (edged knows no variation).
- `navigation.headingTrue` (rad), `navigation.rateOfTurn` (rad/s, + to starboard):
  the spec's, from the manoeuvring state.
- `navigation.leewayAngle` (rad, + when the ship slips to starboard): the spec's
  angle between the heading and the track through the water, the manoeuvring
  state's `drift_angle_water`.
- `navigation.speedOverGround` (m/s), `navigation.courseOverGroundTrue` (rad): the
  spec's, from the manoeuvring state.
- `design.draft` ({current} m): the spec's draft object, whose `current` is "the
  current draft of the vessel": the mean draft. signalk-server keeps its own
  vessel's `design.draft` as configured and drops it from every data connection.
- `edged.draft.mean` (m): the mean draft again, so that signalk-server shows it.
- `edged.draft.marks.<mark>` (m): the spec names no draft mark; the wave-free mean
  of each (null while its sensor is out).
- `edged.draft.trim` (m, + by the stern), `edged.draft.list` (m, port − starboard):
  the spec has only angles (`navigation.attitude`, the instantaneous roll and pitch
  of a motion sensor), not these static differences of drafts.
- `edged.draft.squat` (m): the spec names no squat.
- `environment.depth.belowKeel` (m): the spec's depth below the keel, edged's
  under-keel clearance (the measured depth under the deepest mark).

A value that must not go out as a number (stale, converging, too old, missing) is
`null`, never a stale number; an object member too (the current is `null` as a
whole when neither its set nor its drift is known). A mark whose name is not one
path segment (a dot in it: a foreign recording's) is left out, and counted.
"""

from __future__ import annotations

import re
from typing import Callable

from edged.bridgeview import BridgeView

__all__ = ["Value", "Values", "VALUES", "ROLE_OF", "MARK_RE"]

Value = float | None | dict[str, float | None]
#: The (path, value) pairs of one message.
Values = list[tuple[str, Value]]

#: A mark name that is safe as one path segment (no dot, nothing to escape).
MARK_RE = re.compile(r"[A-Za-z0-9_]+")


def speed(view: BridgeView) -> Values:
    g = view.get
    return [
        ("navigation.speedThroughWater", g("stw", "stw")),
        ("navigation.speedThroughWaterLongitudinal", g("stw", "stw_long")),
        ("navigation.speedThroughWaterTransverse", g("stw", "stw_trans")),
    ]


def current(view: BridgeView) -> Values:
    set_true, drift = view.get("stw", "current_set"), view.get("stw", "current")
    value: Value = None if set_true is None and drift is None else {"setTrue": set_true, "drift": drift}
    return [("environment.current", value)]


def heading(view: BridgeView) -> Values:
    g = view.get
    return [
        ("navigation.headingTrue", g("manoeuvre", "heading")),
        ("navigation.rateOfTurn", g("manoeuvre", "r")),
        ("navigation.leewayAngle", g("manoeuvre", "drift_angle_water")),
    ]


def course(view: BridgeView) -> Values:
    g = view.get
    return [
        ("navigation.speedOverGround", g("manoeuvre", "sog")),
        ("navigation.courseOverGroundTrue", g("manoeuvre", "cog")),
    ]


def draft(view: BridgeView) -> Values:
    g = view.get
    mean = g("draft", "mean_draft")
    out: Values = [
        ("design.draft", {"current": mean}),
        ("edged.draft.mean", mean),
    ]
    out += [(f"edged.draft.marks.{m}", view.mark(m)) for m in view.marks() if MARK_RE.fullmatch(m)]
    out += [
        ("edged.draft.trim", g("draft", "trim")),
        ("edged.draft.list", g("draft", "list")),
        ("edged.draft.squat", g("draft", "squat")),
        ("environment.depth.belowKeel", g("draft", "ukc")),
    ]
    return out


#: Each message's values, by message name.
VALUES: dict[str, Callable[[BridgeView], Values]] = {
    "speed": speed,
    "current": current,
    "heading": heading,
    "course": course,
    "draft": draft,
}

#: The role whose estimate's data time is each message's timestamp.
ROLE_OF: dict[str, str] = {
    "speed": "stw",
    "current": "stw",
    "heading": "manoeuvre",
    "course": "manoeuvre",
    "draft": "draft",
}
