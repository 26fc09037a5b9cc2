"""One way to wrap angles (issue 33): `edged.angles`, for floats and arrays alike."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from edged.angles import TWO_PI, wrap_2pi, wrap_pi

EDGES = [0.0, -0.0, TWO_PI, -TWO_PI, math.pi, -math.pi, -1e-17, TWO_PI - 1e-16, 1e-300, -1e-300, 7.0, -7.0, 1e6]


def test_a_float_and_an_array_wrap_alike_and_never_give_minus_zero_or_two_pi():
    rng = random.Random(3)
    vals = EDGES + [rng.uniform(-100.0, 100.0) for _ in range(20_000)]
    arr = wrap_2pi(np.array(vals))
    for v, w in zip(vals, arr):
        f = wrap_2pi(v)
        assert type(f) is float and f == w and 0.0 <= f < TWO_PI and math.copysign(1.0, f) > 0


@pytest.mark.parametrize(("a", "want"), [(math.radians(1) - math.radians(359), math.radians(2)),
                                         (math.pi, math.pi), (-math.pi, math.pi), (3 * math.pi, math.pi),
                                         (0.0, 0.0)])
def test_a_difference_is_taken_in_minus_pi_to_pi(a, want):
    assert wrap_pi(a) == pytest.approx(want)
    assert float(wrap_pi(np.array([a]))[0]) == pytest.approx(want)
