"""One JSON encoder for every output: NaN and infinity become null and are reported."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from edged.jsonpayload import dumps


def test_plain_payload_is_compact_json_and_not_flagged():
    data, cleaned = dumps({"t": 1.5, "t_src": None, "source": "gyro", "heading": 0.25})
    assert json.loads(data) == {"t": 1.5, "t_src": None, "source": "gyro", "heading": 0.25}
    assert cleaned is False and b" " not in data


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_numbers_become_null_and_are_flagged(bad):
    data, cleaned = dumps({"t": 1.0, "stw": bad, "std": {"u": [0.1, bad]}})
    assert json.loads(data) == {"t": 1.0, "stw": None, "std": {"u": [0.1, None]}}
    assert cleaned is True


def test_numpy_values_and_big_integers_are_encoded():
    data, cleaned = dumps({"x": np.float64(2.5), "P": np.eye(2), "n": np.int64(3), "big": 1 << 70})
    assert json.loads(data) == {"x": 2.5, "P": [[1.0, 0.0], [0.0, 1.0]], "n": 3, "big": 1 << 70}
    assert cleaned is False
    data, cleaned = dumps({"x": np.float64("nan")})
    assert json.loads(data) == {"x": None} and cleaned is True


def test_values_without_json_form_raise():
    with pytest.raises((TypeError, ValueError)):
        dumps({"x": object()})


@pytest.mark.parametrize(
    "payload",
    [
        {"t": 1.0, "t_src": None, "x": math.nan},  # a None beside the NaN: two nulls, one None
        {"t": 1.0, "t_src": None, "v": {"a": None, "b": math.inf}},  # nested: not counted at the top
        {"t": 1.0, "t_src": None, "source": "null", "x": -math.inf},  # "null" in a string as well
        {"t": 1.0, "P": np.array([1.0, np.nan]), "t_src": None},  # a numpy array among the values
    ],
)
def test_a_non_finite_beside_real_nulls_is_still_flagged(payload):
    data, cleaned = dumps(payload)
    assert cleaned is True and b"NaN" not in data and b"Infinity" not in data


def test_nulls_that_are_all_the_objects_own_none_values_are_not_flagged():
    for payload in ({"t": 1.0, "t_src": None, "source": "null"}, {"a": None, "b": None, "c": [1.0]},
                    {"t": 1.0, "P": np.array([1.0, 2.0]), "t_src": None}):
        assert dumps(payload)[1] is False
