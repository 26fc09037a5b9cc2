"""A mark's rhythm: lost readings are counted, a sensor set to a slower rate is not lost."""

from __future__ import annotations

from edged_draft.marks import RATE_CHANGE, MarkState


def test_irregular_gaps_are_counted_as_lost_readings():
    st = MarkState("fore_port")
    t, lost = 0.0, 0
    for i in range(3000):
        t += 0.01 if i % 5 else 0.03  # every fifth interval two readings are missing
        lost += st.heard(t)
    assert lost == 2 * (3000 // 5 - 1)  # the first reading has nothing before it
    assert abs(st.lost_share - 2 / 7) < 0.005


def test_a_sensor_set_to_a_slower_rate_is_learned_not_lost():
    st = MarkState("fore_port")
    t = 0.0
    for _ in range(500):
        t += 0.01
        st.heard(t)
    lost = 0
    for _ in range(2000):  # 50 Hz from now on
        t += 0.02
        lost += st.heard(t)
    assert abs(st.interval - 0.02) < 1e-9
    assert lost == RATE_CHANGE - 1  # until the new rhythm is believed
    assert st.lost_share == 0.0  # the 200 counted have left the window (40 s > LOST_WINDOW)
