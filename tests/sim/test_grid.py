"""The generalisation grid's simulator features (issue 30): the vessels (the yacht's
wave yaw, the autopilot's course changes), the sensor suites as parameters, the frozen
fault and the fault recipes, and `edged sim VESSEL:SUITE[:FAULT]`.

Records are read back from the bytes the simulator writes (NMEA sentences, CAN
frames), so each test checks what a replay would see."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from edged.angles import wrap_pi
from edged.cli import build_parser
from edged_sim.cli import main
from edged_sim.grid import ACCEL_SATURATED, FAULTS, compose, parse
from edged_sim.run import Simulation
from edged_sim.scenarios import SCENARIOS, lookup
from edged_sim.suites import SUITES
from edged_sim.vessels import VESSELS

DEG = math.pi / 180.0


def _truth(sc, duration: float, seed: int = 1, chunk: float = 100.0) -> dict[str, np.ndarray]:
    sim = Simulation(sc, seed=seed, duration=duration)
    parts = [c.truth for c in sim.chunks(chunk)]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def _sentences(sc, duration: float, formatter: str, seed: int = 1, chunk: float = 100.0) -> list[tuple[float, list[str]]]:
    """(time s of the run, fields) of every sentence of one formatter."""
    sim = Simulation(sc, seed=seed, duration=duration)
    out = []
    for c in sim.chunks(chunk):
        for t_us, line in zip(c.nmea.t_us.tolist(), c.nmea.payload):
            body = line[1:line.index("*")].split(",")
            if body[0][2:] == formatter:
                out.append((t_us / 1e6 - sc.start_epoch, body[1:]))
    return out


def _frames(sc, duration: float, pgn: int | None = None, fid: int | None = None, source: int | None = None,
            seed: int = 1, chunk: float = 100.0) -> list[tuple[float, bytes]]:
    """(time s of the run, data) of the single-frame CAN messages asked for."""
    sim = Simulation(sc, seed=seed, duration=duration)
    out = []
    for c in sim.chunks(chunk):
        for t_us, (i, ext, data) in zip(c.can.t_us.tolist(), c.can.payload):
            if ext and pgn is not None and (i >> 8) & 0x3FFFF == pgn and (source is None or i & 0xFF == source):
                out.append((t_us / 1e6 - sc.start_epoch, data))
            elif not ext and fid is not None and i == fid:
                out.append((t_us / 1e6 - sc.start_epoch, data))
    return out


# -- vessels --------------------------------------------------------------------------
def test_yacht_heading_carries_wave_yaw_of_5_degrees_at_3_to_6_s() -> None:
    """The truth heading minus the same run without the wave yaw: RMS amplitude/2
    (significant amplitude 5°), its energy at periods of 3–6 s; the track is the
    low-frequency model's (SOG, COG, position unchanged)."""
    sc = SCENARIOS["yacht-seaway"]
    assert sc.wave_yaw is not None and sc.wave_yaw.amplitude_deg == 5.0
    tr, lf = _truth(sc, 600.0), _truth(replace(sc, wave_yaw=None), 600.0)
    d = wrap_pi(tr["heading"] - lf["heading"])
    assert 2.2 * DEG < d.std() < 2.9 * DEG  # 2.5° nominal
    assert np.abs(d).max() < 12 * DEG
    f = np.fft.rfftfreq(d.size, 0.1)
    power = np.abs(np.fft.rfft(d)) ** 2
    band = (f >= 1 / 6.2) & (f <= 1 / 2.9)
    assert power[band].sum() > 0.98 * power[1:].sum()
    np.testing.assert_allclose(tr["r"] - lf["r"], np.gradient(np.unwrap(d), 0.1), atol=2e-3)
    for col in ("sog", "cog", "x", "y", "stw", "current_along"):
        np.testing.assert_allclose(tr[col], lf[col], atol=1e-9, err_msg=col)
    # The body-axis velocity turns against the yawed heading: |V| is kept, v wobbles.
    np.testing.assert_allclose(np.hypot(tr["u"], tr["v"]), tr["sog"], atol=1e-9)
    assert np.std(tr["v"] - lf["v"]) > 0.05


def test_yacht_truth_stays_self_consistent_with_wave_yaw() -> None:
    """ax, ay are a_u − v·r, a_v + u·r and a_u integrates to u, as without waves."""
    tr = _truth(SCENARIOS["yacht-seaway"], 200.0)
    t = tr["t_rel"]
    np.testing.assert_allclose(tr["ax"], tr["a_u"] - tr["v"] * tr["r"], atol=1e-12)
    np.testing.assert_allclose(tr["ay"], tr["a_v"] + tr["u"] * tr["r"], atol=1e-12)
    for vel, acc in (("u", "a_u"), ("v", "a_v")):
        integ = tr[vel][0] + np.concatenate(([0.0], np.cumsum(0.5 * (tr[acc][1:] + tr[acc][:-1]) * np.diff(t))))
        assert np.max(np.abs(integ - tr[vel])) < 0.02, vel


@pytest.mark.parametrize("vessel", list(VESSELS))
def test_autopilot_changes_course_by_90_degrees_without_large_overshoot(vessel: str) -> None:
    v = VESSELS[vessel]
    sc = replace(compose(v, SUITES["yacht"]), wave_yaw=None)
    tr = _truth(sc, 1140.0)
    h = np.degrees(np.unwrap(tr["heading"]))
    t = tr["t_rel"]
    assert h[t < 119].max() - h[t < 119].min() < 0.5
    assert 120.0 < h.max() < 140.0  # 135° ordered at 120 s: reached within 5°, overshoot < 5°
    assert abs(v.ship.length - {"yacht": 8.5, "coaster": 110.0, "tanker": 300.0}[vessel]) < 1e-9
    # The speed ordered down to 70 % at 420 s (sog includes the 0.5 m/s current).
    assert tr["stw"][t > 600].min() < 0.75 * v.cruise_kn * 0.5144 < tr["stw"][t < 400].min()


def test_tanker_is_more_sluggish_than_the_coaster_and_the_yacht() -> None:
    rates = {}
    for name in VESSELS:
        sc = replace(compose(VESSELS[name], SUITES["yacht"]), wave_yaw=None)
        rates[name] = np.abs(_truth(sc, 400.0)["r"]).max()
    assert rates["yacht"] > 5 * rates["coaster"] > 5 * 1.5 * rates["tanker"]


# -- suites -----------------------------------------------------------------------------
def test_fog_suite_reads_rate_of_turn_to_0_001_deg_per_s() -> None:
    """ROT and PGN 127251 of the FOG suite against the truth at their instants."""
    sc = replace(SCENARIOS["tanker-fog"], wave_yaw=None)
    tr = _truth(sc, 120.0)
    rot = _sentences(sc, 120.0, "ROT")
    t = np.array([x[0] for x in rot])
    r = np.radians(np.array([float(x[1][0]) for x in rot])) / 60.0
    err = r - np.interp(t, tr["t_rel"], tr["r"])
    assert 0.0009 * DEG < err.std() < 0.0011 * DEG
    frames = _frames(sc, 120.0, pgn=127251, source=18)
    t2 = np.array([x[0] for x in frames])
    r2 = np.array([int.from_bytes(d[1:5], "little", signed=True) * 3.125e-8 for _, d in frames])
    assert 0.0009 * DEG < (r2 - np.interp(t2, tr["t_rel"], tr["r"])).std() < 0.0011 * DEG


def test_suite_rates_and_what_is_absent() -> None:
    sc = SCENARIOS["tanker-fog"]
    gga = _sentences(sc, 125.0, "GGA")
    assert np.allclose(np.diff([t for t, _ in gga]), 30.0)  # GNSS every 30 s
    assert len(_sentences(sc, 125.0, "VTG")) == len(gga)
    assert len(_frames(sc, 30.0, fid=0x320)) == 30  # IMU at 1 Hz
    yacht = SCENARIOS["yacht-seaway"]
    assert _frames(yacht, 20.0, fid=0x320) == [] and _sentences(yacht, 20.0, "ROT") == []  # no IMU, no gyro
    assert len(_sentences(yacht, 20.0, "HDT")) == 20  # 1 Hz compass
    ref = parse("coaster:reference")
    assert len(_sentences(ref, 2.0, "GGA")) == 20 and len(_frames(ref, 2.0, fid=0x320)) == 100


def test_second_compass_disagrees_by_25_degrees_on_its_own_address() -> None:
    sc = parse("coaster:two-compasses")
    tr = _truth(sc, 30.0)
    for src, off, sigma in ((18, 0.0, 0.1), (19, 25.0, 0.5)):
        fr = _frames(sc, 30.0, pgn=127250, source=src)
        assert len(fr) == 300
        t = np.array([x[0] for x in fr])
        h = np.array([int.from_bytes(d[1:3], "little") * 1e-4 for _, d in fr])
        e = np.degrees(wrap_pi(h - np.interp(t, tr["t_rel"], np.unwrap(tr["heading"]))))
        assert abs(e.mean() - off) < 0.1 and 0.8 * sigma < e.std() < 1.2 * sigma, src


# -- faults -----------------------------------------------------------------------------
def test_frozen_sensor_repeats_its_last_value_across_chunks() -> None:
    """Frozen over [3, 7) s with 2-s chunks: every HDT inside repeats the last one
    before 3 s; outside, the sentences are those of the same run without the fault."""
    base = replace(parse("coaster:coastal"), duration_s=10.0)
    sc = replace(base, sensors=tuple(replace(s, frozen=((3.0, 7.0),)) if s.name == "gyro.heading" else s
                                     for s in base.sensors))
    got, clean = _sentences(sc, 10.0, "HDT", chunk=2.0), dict((t, f) for t, f in _sentences(base, 10.0, "HDT", chunk=2.0))
    before = [f for t, f in got if t < 3.0][-1]
    inside = [f for t, f in got if 3.0 <= t < 7.0]
    assert len(inside) == 40 and all(f == before for f in inside)
    assert all(f == clean[t] for t, f in got if not 3.0 <= t < 7.0)
    assert len({tuple(f) for t, f in got if t >= 7.0}) > 20  # it moves again
    pgn = [d for t, d in _frames(sc, 10.0, pgn=127250, source=18, chunk=2.0) if 3.0 <= t < 7.0]
    assert len({d[1:3] for d in pgn}) == 1 and len({d[0] for d in pgn}) == 40  # same heading, SID moves on
    w = Simulation(sc, seed=1).meta()["faults"]["windows"]
    assert {"sensor": "gyro.heading", "kind": "frozen", "start_s": 3.0, "end_s": 7.0} in w


def _short(name: str, window: tuple[float, float], suite: str = "coastal"):
    f = replace(FAULTS[name], window=window, duration_s=window[1] + 5.0)
    return compose(VESSELS["coaster"], SUITES[suite], f)


def test_accelerometers_saturate_in_range() -> None:
    sc = _short("accel-saturated", (2.0, 3.0), "reference")
    fr = _frames(sc, sc.duration_s, fid=0x320)
    inside = [d for t, d in fr if 2.0 <= t < 3.0]
    assert len(inside) == 50
    assert all([int.from_bytes(d[i:i + 2], "little", signed=True) for i in (0, 2, 4)] == [32767] * 3 for d in inside)
    assert all(int.from_bytes(d[0:2], "little", signed=True) < 1000 for t, d in fr if not 2.0 <= t < 3.0)
    assert round(ACCEL_SATURATED / 0.001) == 32767


def test_gap_silences_every_sensor() -> None:
    sc = _short("gap-6h", (3.0, 6.0))
    sim = Simulation(sc, seed=1)
    times = [t / 1e6 - sc.start_epoch for c in sim.chunks(2.0) for b in (c.nmea, c.can) for t in b.t_us.tolist()]
    assert times and not any(3.0 <= t < 6.0 for t in times) and max(times) > 6.0
    kinds = {(w["kind"], w["start_s"], w["end_s"]) for w in sim.meta()["faults"]["windows"]}
    assert kinds == {("outage", 3.0, 6.0)}
    assert FAULTS["gap-6h"].window[1] - FAULTS["gap-6h"].window[0] == 6 * 3600.0


def test_position_jumps_10_km_north() -> None:
    sc = _short("position-jump", (2.0, 4.0))
    tr = _truth(sc, sc.duration_s)
    gga = _sentences(sc, sc.duration_s, "GGA")
    for t, f in gga:
        lat = float(f[1][:2]) + float(f[1][2:]) / 60.0
        true = np.interp(t, tr["t_rel"], tr["lat"])
        north = (lat - true) * 111_400.0
        assert abs(north - (10_000.0 if 2.0 <= t < 4.0 else 0.0)) < 60.0
    jumps = Simulation(sc, seed=1).meta()["faults"]["position_jumps"]
    assert {j["sensor"] for j in jumps} == {"gnss1.position", "gnss2.rapid", "gnss2.position"}


def test_doppler_log_reads_zero() -> None:
    sc = _short("dvl-zero", (3.0, 6.0))
    vbw = _sentences(sc, sc.duration_s, "VBW")
    assert [f[:2] for t, f in vbw if 3.0 <= t < 6.0] == [["0.000", "0.000"]] * 3
    assert all(float(f[0]) > 5.0 for t, f in vbw if not 3.0 <= t < 6.0)


def test_fault_on_a_suite_without_its_sensor_is_refused() -> None:
    with pytest.raises(ValueError, match="imu_accel"):
        parse("yacht:yacht:accel-saturated")


def test_named_fault_scenarios_hold_their_window() -> None:
    for name, fault in FAULTS.items():
        sc = SCENARIOS[f"fault-{name}"]
        assert sc.duration_s >= fault.window[1] + 600.0 and sc.name == f"fault-{name}"


# -- the command line -------------------------------------------------------------------
def _sim(out: Path, *argv: str) -> int:
    return main(build_parser().parse_args(["sim", *argv, "--out", str(out)]))


def test_edged_sim_takes_a_composition(tmp_path: Path) -> None:
    assert _sim(tmp_path / "a", "tanker:fog:heading-frozen", "--duration", "3", "--seed", "2") == 0
    meta = json.loads((tmp_path / "a" / "meta.json").read_text())
    assert meta["scenario"] == "tanker:fog:heading-frozen" and meta["ship"]["length"] == 300.0
    assert meta["faults"]["windows"][0]["kind"] == "frozen"
    assert "wave_yaw" not in meta  # the tanker has none
    assert _sim(tmp_path / "b", "yacht-seaway", "--duration", "1") == 0
    yacht = json.loads((tmp_path / "b" / "meta.json").read_text())
    assert yacht["wave_yaw"] == {"amplitude_deg": 5.0, "period_min_s": 3.0, "period_max_s": 6.0, "n": 6}
    assert lookup("yacht-seaway") is SCENARIOS["yacht-seaway"]


@pytest.mark.parametrize("name, what", [("boat:fog", "vessel"), ("yacht:gold", "suite"),
                                        ("yacht:fog:rust", "fault"), ("a:b:c:d", "VESSEL:SUITE")])
def test_edged_sim_names_the_unknown_part(tmp_path: Path, capsys: pytest.CaptureFixture, name: str, what: str) -> None:
    assert _sim(tmp_path / "x", name, "--duration", "1") == 2
    err = capsys.readouterr().err
    assert what in err and "tanker" in err and "heading-frozen" in err
    assert not (tmp_path / "x").exists()
