"""The demo's dashboard drawn from a snapshot at a given time: what it shows, in which
units, and "—" for what is missing or stale (never the last number seen)."""

from __future__ import annotations

import math
from typing import Any

import pytest

from edged_demo import units
from edged_demo.dashboard import STALE_AFTER_S, render_text

NOW = 1_796_426_323.0


def _stw(t: float = NOW - 0.5, **over: Any) -> dict[str, Any]:
    d = {
        "t": t, "kind": "stw", "stale": False, "age": 0.02, "converging": False,
        "stw": 5.0, "stw_std": 0.1, "sog": 6.0, "current": 1.0, "distance": 1234.0, "dvl_stw": 5.5,
        "stw_long": 5.0, "stw_trans": 0.01, "mode": "vector", "current_set": math.radians(180.0),
        "current_along": -1.0, "dvl_bias": 0.4, "dvl_scale": 1.02, "dvl_std": {"bias": 0.05, "scale": 0.004},
    }
    d.update(over)
    return d


def _manoeuvre(t: float = NOW - 0.1, **over: Any) -> dict[str, Any]:
    d = {
        "t": t, "kind": "manoeuvre", "stale": False, "age": 0.01, "converging": False,
        "lat": 57.6, "lon": 11.5, "x": 0.0, "y": 0.0, "u": 4.0, "v": -0.25, "r": math.radians(0.5),
        "heading": math.radians(90.0), "a_u": 0.0, "a_v": 0.0, "sog": 4.0, "cog": math.radians(86.4),
        "drift_angle": math.radians(-3.6), "drift_angle_water": None, "nis": 1.25, "rcond": 1.0,
        "q_scale": {"yaw": 1.0, "translation": 1.0}, "model": "ctra", "filter": "ekf", "mode": "tuned",
        "std": {"u": 0.01, "v": 0.01}, "accel_bias": None,
        "predicted": [
            # 240 m due east of the estimate in 60 s
            {"dt": 60.0, "lat": 57.6, "lon": 11.5 + math.degrees(240.0 / (6_391_000.0 * math.cos(math.radians(57.6)))),
             "heading": math.radians(90.0), "std_major": 12.0, "std_minor": 5.0, "std_angle": 0.0},
        ],
    }
    d.update(over)
    return d


def _draft(t: float = NOW - 0.5, **over: Any) -> dict[str, Any]:
    marks = {m: {"draft": 7.0 + i / 100, "mean": 7.0, "rate": 0.0, "amplitude": 0.3, "std": 0.1, "ok": True}
             for i, m in enumerate(("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd"))}
    marks["aft_stbd"]["ok"] = False
    d = {
        "t": t, "kind": "draft", "stale": False, "age": 0.0, "converging": False, "marks": marks,
        "mean_draft": 7.25, "mean_draft_std": 0.05, "filled": ["aft_stbd"], "trim": 0.58, "list": -0.12,
        "heel": None, "deflection": 0.03, "squat": 0.21, "squat_std": 0.02, "ukc": 12.5,
    }
    d.update(over)
    return d


def _health(t: float = NOW - 0.4) -> dict[str, Any]:
    def comp(role: str, type_: str, **kw: Any) -> dict[str, Any]:
        return {"role": role, "type": type_, "state": "running", "ok": True, "problems": [], "counters": {},
                "rates": {}, "last_error": None, "restarts": 0, **kw}

    return {
        "t": t, "ok": False, "vessel_id": "v1",
        "inputs": {
            "nmea": comp("input", "nmea0183", state="connected",
                         counters={"lines": 900, "rejected.bad_checksum": 3, "rejected.too_long": 1, "dropped.kernel": 0},
                         rates={"lines": 43.0, "measurements.position": 10.0, "measurements.heading": 10.0}),
            "can0": comp("input", "can", state="stale", ok=False,
                         counters={"frames": 10}, rates={"frames": 0.0, "measurements.draft": 0.0}),
        },
        "estimators": {
            "draft": comp("estimator", "draft", info={"filter": {"out": ["aft_stbd"],
                                                                 "marks": {"aft_stbd": {"ok": False, "why": "frozen"}},
                                                                 "rigid": {"chi2_per_dof": 1.5, "used": True}}}),
            "stw": comp("estimator", "stw", rates={"estimates": 1.0}, info={"filter": {
                "innovation": {"position": {"dof": 2, "updates": 300, "gated": 4, "window": 100, "nis_mean": 2.2,
                                            "in_band_95": 0.94}},
                "rejected": {"water_speed.gate": 7}, "dvl": {"published": True, "reason": None}}}),
            "manoeuvre": comp("estimator", "manoeuvre", ok=False,
                              problems=["heading: NIS mean 12.0 above 5 x its dof"],
                              info={"stale": False, "filter": {"innovation": {
                                  "heading": {"dof": 1, "updates": 100, "gated": 0, "window": 50, "nis_mean": 12.0,
                                              "in_band_95": 0.3}}}}),
        },
        "outputs": {"recorder": comp("output", "mcap", state="recording", counters={"recorded": 5000},
                                     info={"file": "/rec/edged-x.mcap"})},
    }


def _snapshot(**over: Any) -> dict[str, Any]:
    snap = {"estimates": {"stw": _stw(), "manoeuvre": _manoeuvre(), "draft": _draft()}, "health": _health(),
            "vessel_id": "v1", "started": NOW - 90.0}
    snap.update(over)
    return snap


def _line(text: str, label: str) -> str:
    """The dashboard's line that has `label` (the first)."""
    for line in text.splitlines():
        if label in line:
            return line
    raise AssertionError(f"no line with {label!r} in\n{text}")


def test_speeds_are_shown_in_knots_and_metres_per_second_beside_the_log_and_sog():
    text = render_text(_snapshot(), NOW, width=200)
    assert "9.72 kn  5.00 m/s" in _line(text, "STW   ")  # 5.0 m/s
    assert "±0.19 kn" in _line(text, "STW   ")
    assert "10.69 kn  5.50 m/s" in _line(text, "STW, Doppler log")
    assert "11.66 kn  6.00 m/s" in _line(text, "SOG   ")
    assert "+0.97 kn  +0.50 m/s" in _line(text, "log − STW")
    offset = _line(text, "log offset")
    assert "+0.78 kn  +0.40 m/s" in offset and "±0.10 kn  0.05 m/s" in offset
    assert "1.020  ±0.004" in _line(text, "log scale")
    assert "toward 180.0°" in _line(text, "current  ")


def test_manoeuvring_state_and_predicted_track_in_degrees():
    text = render_text(_snapshot(), NOW, width=200)
    assert "+7.78 kn  +4.00 m/s" in _line(text, "u, surge")
    assert "-0.49 kn  -0.25 m/s" in _line(text, "v, sway")
    assert "+0.50°/s  +30°/min" in _line(text, "r, yaw rate")
    assert "090.0°" in _line(text, "│ heading ")
    assert "-3.6°" in _line(text, "drift angle")
    assert "57.60000°N 011.50000°E" in _line(text, "│ position")
    row = _line(text, "+60 s")
    assert "240 m at 090.0°" in row and "12 m" in row


def test_drafts_trim_list_squat_and_ukc_in_metres():
    text = render_text(_snapshot(), NOW, width=200)
    assert "7.25 m  ±0.05 m" in _line(text, "mean draft")
    assert "0.58 m by the stern" in _line(text, "trim  ")
    assert "0.12 m to starboard" in _line(text, "list  ")
    assert "0.21 m  ±0.02 m" in _line(text, "squat")
    assert "12.50 m" in _line(text, "UKC")
    aft = _line(text, "aft_stbd  ")
    assert "7.05 m" in aft and "frozen" in aft and "filled" in aft
    assert "✓ ok" in _line(text, "fore_port  ")


def test_sources_rates_and_rejections_per_reason():
    text = render_text(_snapshot(), NOW, width=200)
    nmea = _line(text, "nmea0183")
    assert "connected" in nmea and "✓ ok" in nmea and "20" in nmea and "43 lines" in nmea
    assert "bad_checksum: 3" in text and "too_long: 1" in text
    assert "dropped.kernel" not in text  # nothing dropped: not shown
    can = _line(text, " can0 ")
    assert "stale" in can and "✗ not ok" in can


def test_estimator_health_nis_problems_and_state():
    text = render_text(_snapshot(), NOW, width=220)
    stw = _line(text, " stw ")
    assert "position 1.10 94% gated 4" in stw and "water_speed.gate 7" in stw
    man = _line(text, " manoeuvre ")
    assert "✗ not ok" in man and "heading 12.00 30%" in man
    assert "heading: NIS mean 12.0 above 5 x its dof" in text
    assert "marks out: aft_stbd" in text and "χ²/dof 1.50" in text
    assert "recorder recording ✓ ok 5000 records -> /rec/edged-x.mcap" in text


@pytest.mark.parametrize(
    "stw",
    [
        _stw(stale=True, age=12.0),  # the estimator says so
        _stw(t=NOW - STALE_AFTER_S - 1.0),  # it stopped publishing
    ],
    ids=["flagged-stale", "too-old"],
)
def test_a_stale_estimate_shows_dashes_not_its_last_numbers(stw):
    text = render_text(_snapshot(estimates={"stw": stw, "manoeuvre": _manoeuvre(), "draft": _draft()}), NOW)
    assert "9.72 kn" not in text and "10.69 kn" not in text
    for label in ("STW   ", "STW, Doppler log", "SOG   ", "log offset", "log scale", "current  "):
        assert units.DASH in _line(text, label), label
    assert "stale" in _line(text, "Speed through water")
    assert "+7.78 kn" in text  # the others are fresh


def test_missing_estimates_and_health_show_dashes():
    text = render_text({"estimates": {}, "health": None}, NOW)
    assert "no estimate yet" in text and "waiting for the first health snapshot" in text
    for label in ("STW   ", "u, surge", "│ heading ", "mean draft", "trim  ", "UKC"):
        assert units.DASH in _line(text, label), label
    assert "kn" not in text and " m/s" not in text


def test_an_old_health_snapshot_shows_no_rates():
    text = render_text(_snapshot(health=_health(t=NOW - 30.0)), NOW, width=200)
    assert "health snapshot 30.0 s old" in text
    assert "43 lines" not in text and "bad_checksum" not in text
    assert units.DASH in _line(text, "nmea0183")


def test_a_narrow_terminal_still_shows_every_part():
    text = render_text(_snapshot(), NOW, width=80)
    for part in ("Sources", "Speed through water", "Manoeuvring", "Draft", "Estimators", "9.72 kn"):
        assert part in text


def test_units():
    assert units.knots(5.0) == "9.72 kn"
    assert units.heading(math.radians(359.96)) == "000.0°" and units.heading(-math.pi / 2) == "270.0°"
    assert units.angle(math.radians(190.0)) == "-170.0°" and units.angle(math.pi) == "+180.0°"
    for bad in (None, float("nan"), float("inf"), True, "5"):
        assert units.speed(bad) == units.DASH and units.metres(bad) == units.DASH
    assert units.position(-33.5, -70.25) == "33.50000°S 070.25000°W"
    assert units.distance(513_021_496.8) == ">1000 km" and units.distance(7387.4) == "7.4 km"
