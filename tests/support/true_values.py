"""The contract every decoder's fuzz test asserts of what it emits (DESIGN §8)."""

from __future__ import annotations

import math
from typing import Iterable

from edged.angles import TWO_PI
from edged.records import KINDS, Measurement, validate_measurement


def assert_true_values(ms: Iterable[Measurement]) -> None:
    """Inside its kind's bounds, finite, angles in [0, 2π), no −0.0 in an angle or a
    coordinate, and a finite sensor time when there is one."""
    for m in ms:
        validate_measurement(m.kind, m.values)
        for f in KINDS[m.kind].fields:
            v = m.values.get(f.name)
            if v is None or f.unit == "name":
                continue
            assert math.isfinite(v), (m, f.name)
            if f.angle:
                assert 0.0 <= v < TWO_PI, (m, f.name)
            if f.unit in ("rad", "deg") and v == 0.0:  # headings, lat/lon, roll/pitch
                assert math.copysign(1.0, v) == 1.0, (m, f.name)  # no -0.0
        assert m.t_src is None or math.isfinite(m.t_src), m
