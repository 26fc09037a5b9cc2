"""The one definition of measurement kinds rejects what cannot be true."""

from __future__ import annotations

import math

import pytest

from edged.angles import wrap_2pi
from edged.records import KINDS, InvalidMeasurement, Measurement, measurement_to_json, validate_measurement


def test_valid_measurements_pass():
    validate_measurement("position", {"lat": 59.9, "lon": 10.7, "fix_quality": 1})
    validate_measurement("draft", {"mark": "fore_port", "draft": 10.0, "status": 1})
    validate_measurement("heading", {"heading": 6.2})


@pytest.mark.parametrize(
    "kind, values, why",
    [
        ("nope", {"x": 1}, "unknown kind"),
        ("position", {"lat": 91.0, "lon": 0.0}, "outside"),
        ("position", {"lat": float("nan"), "lon": 0.0}, "is nan"),
        ("position", {"lon": 0.0}, "lat missing"),
        ("velocity_ground", {"sog": -0.1}, "outside"),
        ("velocity_ground", {"sog": math.inf}, "is inf"),
        ("current", {"set": 1.0, "drift": "fast"}, "not a number"),
        ("heading", {"heading": 7.0}, "outside"),
        ("heading", {"heading": 1.0, "bogus": 2}, "unknown field"),
        ("draft", {"mark": "", "draft": 1.0, "status": 0}, "non-empty name"),
        ("draft", {"mark": 3, "draft": 1.0, "status": 0}, "non-empty name"),
        ("yaw_rate", {"r": object()}, "not a number"),
    ],
)
def test_impossible_values_are_rejected_naming_the_field(kind, values, why):
    with pytest.raises(InvalidMeasurement, match=why):
        validate_measurement(kind, values)


def test_every_kind_has_si_units_and_angles_bounded():
    for spec in KINDS.values():
        for f in spec.fields:
            assert f.unit in {"deg", "1", "m", "m/s", "m/s^2", "rad", "rad/s", "name"}, (spec.name, f)
            if f.angle:
                assert (f.lo, f.hi) == (0.0, 2 * math.pi)


def test_wrap_2pi_stays_in_range():
    assert wrap_2pi(-0.1) == pytest.approx(2 * math.pi - 0.1)
    assert wrap_2pi(2 * math.pi) == 0.0
    assert wrap_2pi(-1e-18) == 0.0  # rounds to 2π, which is not in [0, 2π)


def test_json_form_is_the_contract():
    m = Measurement("heading", "gyro", 10.5, {"heading": 1.0}, t_src=10.4)
    assert measurement_to_json(m) == {"t": 10.5, "t_src": 10.4, "source": "gyro", "heading": 1.0}


def test_records_reach_a_process_worker_whole():
    """A process worker gets its inputs pickled: every field comes back, source times
    and an unknown estimate kind included."""
    import pickle

    from edged.records import Estimate

    for rec in (Measurement("draft", "can0.DraftMark", 1.5, {"mark": "aft_port", "draft": 9.87}, t_src=1.25),
                Measurement("heading", "gyro", 2.0, {"heading": 0.5}),
                Estimate("stw", "stw", 3.0, {"stw": 5.1, "stw_std": None}, kind="stw"),
                Estimate("x", "x", 4.0, {}, kind=None)):
        back = pickle.loads(pickle.dumps(rec, protocol=pickle.HIGHEST_PROTOCOL))
        assert type(back) is type(rec) and back == rec
        assert getattr(back, "t_src", None) == getattr(rec, "t_src", None)
