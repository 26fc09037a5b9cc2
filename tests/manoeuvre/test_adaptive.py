"""The process-noise adaptation (`edged_manoeuvre.adaptive.QScale`): an order caught in
a second, and its boost given back when the NIS says the model fits again."""

from __future__ import annotations

from edged_manoeuvre.adaptive import QScale


def _feed(q: QScale, t0: float, seconds: float, nis: float, rate: float = 10.0) -> float:
    n = int(round(seconds * rate))
    for k in range(n):
        q.add(t0 + k / rate, nis, 1)
    return t0 + n / rate


def test_an_order_raises_the_boost_within_a_second():
    q = QScale()
    t = _feed(q, 0.0, 200.0, 1.0)
    assert q.boost == 1.0
    _feed(q, t, 1.0, 30.0)  # the yaw rate far off what the model expected
    assert q.boost > 10.0


def test_a_boost_too_high_for_a_longer_span_falls_in_seconds():
    """After the order the NIS sits at 0.6 per degree of freedom: inside the 2-s band
    (20 dof: from 0.48), below the 8-s one (80 dof: from 0.71). The 8-s evidence takes
    the boost down as the NIS says; relaxing on the 10-s clock alone would leave it at
    five times the level 25 s later (1 + 49·e^(−2.5))."""
    q = QScale()
    t = _feed(q, 0.0, 200.0, 1.0)
    t = _feed(q, t, 1.5, 30.0)
    q.boost = 50.0  # whatever the order took it to
    _feed(q, t, 25.0, 0.6)
    assert q.boost < 3.0


def test_a_boost_that_fits_is_kept():
    """A steady turn needs the boost it has: NIS at 1 within the band holds it."""
    q = QScale()
    t = _feed(q, 0.0, 200.0, 1.0)
    t = _feed(q, t, 1.5, 30.0)
    b = q.boost
    _feed(q, t, 30.0, 1.0)
    assert q.boost == b
