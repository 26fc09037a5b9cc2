"""The inputs of the STW core: which kinds move the ground filter, which the health
watches, what a vessel loses without each, and the check every reading passes first."""

from __future__ import annotations

import math
from typing import Any

from edged.units import finite_numbers

#: What a vessel loses without each input (health `info.filter.missing`).
COSTS: dict[str, str] = {
    "position": "no GNSS position: velocity from SOG/COG alone, no distance check of the speed",
    "velocity_ground": "no SOG/COG: the ground velocity comes from successive positions only",
    "heading": "no heading: COG stands in for it, so stw_long/stw_trans are along/across the track, "
               "the drift angle is not seen and the cross current comes from forecasts alone",
    "accel_body": "no IMU: the acceleration is seen only through changes of SOG (slower response to speed changes)",
    "current": "no current forecast: the current is unknown (σ grows to current_sigma_max), "
               "so STW is SOG with that uncertainty",
    "water_speed": "no Doppler/EM log: dvl_stw, dvl_bias and dvl_scale are null",
    "yaw_rate": "no rate-of-turn sensor: turns are found from the heading's changes, a few seconds late",
}
#: Kinds that move the ground filter: a gap in them is a gap in the data.
GROUND = frozenset({"position", "velocity_ground"})
#: Kinds whose NIS health watches (the log has its own watch: it never moves the estimate).
WATCHED = ("position", "velocity_ground", "accel_body", "heading_course", "current")


def finite(*xs: Any) -> bool:
    """`edged.units.finite_numbers` (real numbers, not bools, finite), its common case
    first: a float is checked here, anything else there. It runs for every reading,
    140 times a second of data, and the general test costs a microsecond."""
    for x in xs:
        if type(x) is not float or not math.isfinite(x):
            return finite_numbers(*xs)
    return True
