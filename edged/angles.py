"""Angles: the one way to wrap them, for the core and every plugin.

Every angle edged emits is in [0, 2π) (`wrap_2pi`); differences of angles are taken in
(−π, π] (`wrap_pi`): 1° − 359° is +2°, not −358°. Both take a float or a numpy array.
Before, the core's records, the manoeuvre model and the simulator each had their own
(issue 33); measured equal on 200,000 values and the edge cases (−0.0, 2π, −1e-17).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

__all__ = ["TWO_PI", "wrap_2pi", "wrap_pi"]

TWO_PI = 2.0 * math.pi


def wrap_2pi(a: np.ndarray | float) -> np.ndarray | float:
    """An angle in [0, 2π): a float for a float (−0.0 and a negative hair that rounds
    to 2π give 0.0), an array for an array. For sums of angles each in range (a
    magnetic heading plus a variation), not a way to accept a reading out of range."""
    if isinstance(a, (float, int)):  # the decoders' path: no numpy call per sentence
        w = math.fmod(a, TWO_PI)
        if w < 0.0:
            w += TWO_PI
        # fmod of a hair below 2π plus 2π may round to 2π itself; `w == 0.0` is also
        # true of −0.0, which must never be emitted
        return 0.0 if w >= TWO_PI or w == 0.0 else w
    import numpy as np  # (here: the core's records import this module, numpy-free)

    w = np.mod(a, TWO_PI)
    if isinstance(w, np.ndarray):
        return np.where(w >= TWO_PI, 0.0, w)
    return 0.0 if w >= TWO_PI else float(w)


def wrap_pi(a: np.ndarray | float) -> np.ndarray | float:
    """An angle or angle difference in (−π, π]."""
    return math.pi - (math.pi - a) % TWO_PI
