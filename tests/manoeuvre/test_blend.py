"""The prediction's blend (`blend.py`): what it takes from the track before it trusts a
candidate over dead reckoning."""

from __future__ import annotations

import numpy as np

from edged_manoeuvre.blend import ForecastBlend

NAMES = ("model", "dead_reckoning")


def _feed(blend: ForecastBlend, seconds: int, model_err: float, dr_err: float) -> list[float]:
    """One prediction a second at (0, 0) for both candidates; the fix at their due time
    lies dr_err north of dead reckoning's point and model_err north of the model's.
    Returns the model's weight after each second."""
    to_ne = lambda lat, lon: (lat, lon)  # noqa: E731 (the candidates' plane is the fix's)
    w = []
    for t in range(seconds):
        blend.add(float(t), np.array([[dr_err - model_err, 0.0], [0.0, 0.0]]))
        blend.due(float(t), to_ne, (dr_err, 0.0), (0.0, 0.0))
        w.append(float(blend.weights[0]))
    return w


def test_a_better_model_is_taken_only_once_its_errors_span_two_horizons():
    """A minute's 20 errors of a 60-s prediction are one or two independent samples (Aava,
    a yacht: the model taken on them made the 60-s prediction 1.05x dead reckoning)."""
    h = 60.0
    blend = ForecastBlend(h, NAMES, "dead_reckoning", window=600.0)
    w = _feed(blend, 400, model_err=1.0, dr_err=5.0)
    first_due = int(h)
    assert max(w[: first_due + int(2 * h)]) == 0.0  # 20 samples came due at 80 s
    assert w[-1] == 1.0  # then the model, five times better over 2 horizons


def test_a_model_not_a_quarter_better_is_not_taken():
    blend = ForecastBlend(10.0, NAMES, "dead_reckoning", window=600.0)
    w = _feed(blend, 200, model_err=4.5, dr_err=5.0)  # J: 20.25 against 25, 19 % better
    assert max(w) == 0.0
