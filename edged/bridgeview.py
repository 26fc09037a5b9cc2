"""The latest fused values, in SI units, as a bridge output sends them.

A value an instrument must not take as a measurement is None here, and each output
turns None into its format's "not available" (an empty NMEA 0183 field with status
V, an N2K field's "no data" code, a null in a Signal K delta): an estimate that is
stale (its inputs stopped, `stale`), still converging, missing, or more than
`max_age` seconds of data time away from the estimate being sent (the one that
arrived last: a heading beside an STW must be of about the same moment), and a draft
mark whose sensor is out (`ok` false). A number sent is never a stale number.

The age is judged against the estimate that arrived, not the newest ever seen. In
a replay the bridge outputs take the estimates in the order of the records they were
made from (`OutputPlugin.ordered`), so a message that combines two estimators (VHW's
heading beside its STW) is what live sent, however far apart their processes ran.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from .records import Estimate

__all__ = ["ROLES", "Roles", "BridgeView"]

#: The estimates a bridge output reads, by role: the kind of estimate it is.
ROLES: tuple[str, ...] = ("stw", "manoeuvre", "draft")


@dataclass(frozen=True, slots=True)
class Roles:
    """The estimator instance (its table name) that plays each role; "" for none."""

    stw: str = "stw"
    manoeuvre: str = "manoeuvre"
    draft: str = "draft"

    def by_name(self) -> dict[str, str]:
        """Estimator instance name -> role, for the roles that are played."""
        return {name: role for role in ROLES if (name := getattr(self, role))}


def _number(v: Any) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    f = float(v)
    return f if math.isfinite(f) else None


class BridgeView:
    """The latest estimate of each role and its values, None where not to be sent."""

    __slots__ = ("roles", "max_age", "t", "_latest", "_role_of")

    def __init__(self, roles: Roles, max_age: float = 5.0) -> None:
        self.roles = roles
        self.max_age = max_age
        #: The data time (s, UNIX) of the estimate that arrived last; None before.
        self.t: float | None = None
        self._latest: dict[str, Estimate] = {}
        self._role_of = roles.by_name()

    @property
    def keys(self) -> frozenset[str]:
        """The route keys (`est/<name>`) of the estimates this view reads."""
        return frozenset(f"est/{n}" for n in self._role_of)

    def update(self, est: Estimate) -> str | None:
        """Take an estimate; the role it plays, or None when it plays none."""
        role = self._role_of.get(est.name)
        if role is None:
            return None
        self._latest[role] = est
        self.t = est.t
        return role

    def valid(self, role: str) -> bool:
        """Whether the role's latest estimate may be sent as numbers."""
        e = self._latest.get(role)
        if e is None:
            return False
        v = e.values
        if v.get("stale") or v.get("converging"):
            return False
        return self.t is None or abs(self.t - e.t) <= self.max_age

    def get(self, role: str, field: str) -> float | None:
        """A number of the role's latest estimate (SI), None where not to be sent."""
        if not self.valid(role):
            return None
        return _number(self._latest[role].values.get(field))

    def time_of(self, role: str) -> float | None:
        """The data time of the role's latest estimate (valid or not)."""
        e = self._latest.get(role)
        return None if e is None else e.t

    def marks(self) -> tuple[str, ...]:
        """The draft marks of the latest draft estimate, in its order."""
        e = self._latest.get("draft")
        marks = e.values.get("marks") if e is not None else None
        return tuple(marks) if isinstance(marks, dict) else ()

    def mark(self, mark: str, field: str = "mean") -> float | None:
        """A draft mark's value (the wave-free `mean` by default), None where the
        draft estimate is not to be sent or the mark is out (`ok` false)."""
        if not self.valid("draft"):
            return None
        marks = self._latest["draft"].values.get("marks")
        m = marks.get(mark) if isinstance(marks, dict) else None
        if not isinstance(m, dict) or m.get("ok") is False:
            return None
        return _number(m.get(field))
