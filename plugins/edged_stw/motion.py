"""How the vessel turns, as the STW core uses it: its heading, its rate of turn, and
whether it is turning (or has just been).

The heading sensor's smoothed track (`heading.HeadingTrack`) and a rate-of-turn
sensor's latest reading are kept here. Heading − course sees the cross current only
on a steady course, and the log is fitted only when the hull no longer sways: both ask
`turning`.
"""

from __future__ import annotations

import math

from .heading import HeadingTrack

#: Inputs of each kind older than this (s) are not used as "the latest".
HEADING_MAX_AGE = 30.0
YAW_RATE_MAX_AGE = 5.0


class Motion:
    def __init__(self, heading_average: float, turn_rate_max_deg: float, turn_settle: float) -> None:
        self.heading = HeadingTrack(heading_average)
        self.turn_rate_max = math.radians(turn_rate_max_deg)
        self.turn_settle = turn_settle
        self.rot: tuple[float, float] | None = None  # t, rad/s from a rate-of-turn sensor
        self._turn_t = -math.inf  # data time of the last sign of a turn

    def heading_at(self, t: float) -> float | None:
        """The smoothed heading, when the gyro is still talking."""
        if not self.heading.fresh(t, HEADING_MAX_AGE):
            return None
        return self.heading.smoothed()

    def rate(self, t: float) -> float:
        """The rate of turn the ground velocity turns by: the gyro's, else the smoothed
        heading's, else 0 (rad/s)."""
        rot = self.rot
        if rot is not None and t - rot[0] <= YAW_RATE_MAX_AGE:
            return rot[1]
        rate = self.heading.rate
        if rate is not None and t - rate[0] <= 2.0 * 5.0 and self.heading.fresh(t, 2.0):
            return rate[1]
        return 0.0

    def turning(self, t: float) -> bool:
        """Turning now, or less than `turn_settle` s ago: the hull still sways."""
        if self._turning_now(t):
            self._turn_t = t
            return True
        return t - self._turn_t < self.turn_settle

    def _turning_now(self, t: float) -> bool:
        rot = self.rot
        if rot is not None and t - rot[0] <= YAW_RATE_MAX_AGE:
            r = rot[1]
        elif self.heading.rate is not None and t - self.heading.rate[0] <= HEADING_MAX_AGE:
            r = self.heading.rate[1]
        else:
            return False
        if abs(r) > self.turn_rate_max:
            return True
        return self.heading.fresh(t, HEADING_MAX_AGE) and not self.heading.settled()
