"""What the six marks give a chief officer and a pilot (`edged_draft.derived`)."""

from __future__ import annotations

import math

import pytest

from edged_draft import derived

#: 10 m mean, trim 0.3 by the stern, list 0.05 to port, sagging 0.04.
MEANS = {"fore_port": 9.875, "fore_stbd": 9.825, "mid_port": 10.065, "mid_stbd": 10.015,
         "aft_port": 10.175, "aft_stbd": 10.125}


def test_the_floating_position_from_six_marks():
    p = derived.floating_position(MEANS, beam=32.2)
    assert p["trim"] == pytest.approx(0.3)
    assert p["list"] == pytest.approx(0.05)
    assert p["deflection"] == pytest.approx(0.04)
    assert p["mean_draft"] == pytest.approx(sum(MEANS.values()) / 6)
    assert p["heel"] == pytest.approx(math.atan2(0.05, 32.2))
    assert derived.floating_position(MEANS, beam=None)["heel"] is None


@pytest.mark.parametrize("mark", derived.MARKS)
def test_a_missing_mark_is_filled_from_its_partner_and_the_list_elsewhere(mark):
    means = {**MEANS, mark: None}
    assert derived.fill(mark, means) == pytest.approx(MEANS[mark])


def test_a_mark_whose_partner_is_out_too_cannot_be_filled_and_the_whole_stations_say_the_mean():
    means = {**MEANS, "fore_port": None, "fore_stbd": None}
    assert derived.fill("fore_port", means) is None
    p = derived.floating_position(means, None)
    assert p["trim"] is None and p["deflection"] is None
    assert p["mean_draft"] == pytest.approx((10.04 + 10.15) / 2)


def test_barrass_squat_in_open_water_and_in_a_channel():
    """S_max = K·C_b·V²/100: open water K = 1; blockage 0.25, K = 5.74·0.25^0.76 ≈ 2."""
    v10 = 10 * 1852 / 3600
    assert derived.barrass_squat(v10, 0.8, None) == pytest.approx(0.8, rel=0.01)
    assert derived.barrass_squat(v10, 0.8, 0.25) == pytest.approx(5.74 * 0.25**0.76 * 0.8, rel=1e-9)
    assert derived.barrass_squat(v10, 0.8, 0.25) == pytest.approx(1.6, rel=0.01)  # seed 003 §7.4


def test_under_keel_clearance_from_the_sounder_and_the_draft_line():
    at = derived.draft_at(0.3 * 225.0, fore=9.85, aft=10.15, spacing=225.0)
    assert at == pytest.approx(10.0 - 0.3 * 0.3)
    # 8 m under a transducer on the keel where the hull draws 9.91: 17.91 m of water;
    # 0.5 m above the keel, 17.41 m
    assert derived.water_depth(8.0, at, 0.0) == pytest.approx(17.91)
    assert derived.water_depth(8.0, at, 0.5) == pytest.approx(17.41)


def test_displacement_change_from_tpc_and_from_a_hydrostatic_table():
    change, per_m = derived.displacement(10.0, 120.0, None, reference=10.01)
    assert change == pytest.approx(-120.0) and per_m == pytest.approx(12000.0)
    table = [(9.0, 100_000.0), (10.0, 112_000.0), (11.0, 125_000.0)]
    change, per_m = derived.displacement(10.5, None, table, reference=10.0)
    assert change == pytest.approx(6500.0) and per_m == pytest.approx(13000.0)
    assert derived.displacement(10.0, None, None, 10.0) is None


def test_six_marks_on_a_rigid_hull_share_their_wave_motion():
    """Wave parts that heave, pitch and roll fit exactly; independent errors are
    halved in variance by the fit."""
    waves = {m: (0.3 + 0.2 * derived.RIGID[m][1] - 0.1 * derived.RIGID[m][2], 1e-4) for m in derived.MARKS}
    got = derived.rigid_waves(waves)
    assert got is not None
    for m in derived.MARKS:
        assert got[m][0] == pytest.approx(waves[m][0])
        assert got[m][1] < 0.75e-4
    assert derived.rigid_waves({m: waves[m] for m in derived.MARKS[:3]}) is None
