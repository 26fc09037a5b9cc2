"""A mark's rhythm: lost readings are counted, a sensor set to a slower rate is not lost."""

from __future__ import annotations

from edged_draft.marks import RHYTHM_WINDOW, MarkState


def test_irregular_gaps_are_counted_as_lost_readings():
    st = MarkState("fore_port")
    t, lost = 0.0, 0
    for i in range(3000):
        t += 0.01 if i % 5 else 0.03  # every fifth interval two readings are missing
        lost += st.heard(t)
    # nothing is judged over the first RHYTHM_WINDOW s (0.6 s of data time a 5-reading cycle)
    judged = sum(1 for k in range(3000 // 5) if (k * 0.07 + 0.07) > RHYTHM_WINDOW + 0.07)
    assert abs(lost - 2 * judged) <= 4, (lost, judged)
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
    assert 0 < lost < 120  # until three quarters of the 2-s window say so
    assert st.lost_share == 0.0  # those have left the window (40 s > LOST_WINDOW)


def test_a_burst_of_frames_at_start_up_is_not_taken_for_the_rhythm():
    """The demo's first frames come 0.1–1.8 ms apart, then every 10 ms: no reading is
    counted lost and the rhythm is the sensor's (it was the burst's: 54,230 counted
    lost of 17,000 received, every mark out for 20 s)."""
    st = MarkState("fore_port")
    t, lost = 0.0, 0
    for i in range(40):
        t += 0.0001 + 0.0017 * (i % 3) / 2
        lost += st.heard(t)
    for _ in range(1000):
        t += 0.01
        lost += st.heard(t)
    assert lost == 0
    assert abs(st.interval - 0.01) < 1e-9
    assert st.lost_share == 0.0


def test_a_mark_dropping_every_other_frame_is_seen_within_a_few_seconds():
    st = MarkState("fore_port")
    t = 0.0
    for _ in range(300):
        t += 0.01
        st.heard(t)
    for i in range(300):  # a frame lost after two readings in three: 200 lost of 500 due
        t += 0.02 if i % 3 else 0.01
        st.heard(t)
    assert abs(st.interval - 0.01) < 1e-9  # the losses are not taken for a slower rhythm
    assert abs(st.lost_share - 200 / 800) < 1e-9  # the 10-s window: 300 sound readings, then these


def test_a_mark_stuck_at_one_value_is_frozen_until_it_moves():
    st = MarkState("fore_port")
    t = 0.0
    frozen = []
    for _ in range(4000):  # 40 s of one value at 100 Hz
        t += 0.01
        frozen.append(st.frozen(t, 7.123))
    assert not any(frozen[:2990]) and all(frozen[3000:])  # from 30 s on
    assert not st.frozen(t + 0.01, 7.124)


def test_a_mark_with_a_frame_counter_is_judged_by_it_not_by_delivery_times():
    """A live bus under load delivers frames in bursts (0.1 ms apart, then 100 ms of
    nothing): by the rhythm 6,000 of 17,000 readings looked lost and every mark went
    out for `gaps`. The frame counter's `lost` is the sensor's own word."""
    st = MarkState("fore_port")
    t, lost = 0.0, 0
    for burst in range(100):
        for i in range(10):
            t += 0.0001
            lost += st.heard(t, 0)
        t += 0.099
    assert lost == 0 and st.lost_share == 0.0
    for _ in range(50):  # then two frames lost before every reading
        t += 0.03
        lost += st.heard(t, 2)
    # the 10-s window: 85 bursts of 10 and these 50, 100 lost among them
    assert lost == 100 and abs(st.lost_share - 100 / (100 + 850 + 50)) < 0.01
