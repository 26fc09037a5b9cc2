"""The logs carry the truth: decode what the sim writes with independent decoders
(pynmea2, nmea2000 on canboat's definitions, cantools on the DBC) and compare with the
truth at each record's own instant, within the format's resolution. Sensors are made
perfect for this (Scenario.without_errors), so any difference is an encoding error."""

from __future__ import annotations

import re
from collections import defaultdict

import numpy as np
import pynmea2
import pytest
from nmea2000 import NMEA2000Decoder

from edged.angles import wrap_pi
from edged.units import KNOT
from edged_sim import n2k, nmea0183
from edged_sim.dbc import DRAFT_IDS
from edged_sim.run import Simulation
from edged_sim.scenarios import SCENARIOS
from edged_sim.writers import candump_lines, nmea_lines

TAG = re.compile(r"^\\c:(\d+\.\d{3})\*([0-9A-F]{2})\\(\$.*)$")
CANDUMP = re.compile(r"^\((\d+\.\d{6})\) can0 ([0-9A-F]{3}|[0-9A-F]{8})#([0-9A-F]*)$")


def _xor(text: str) -> int:
    x = 0
    for ch in text.encode():
        x ^= ch
    return x


def _angle_close(a, b, tol):
    return np.all(np.abs(wrap_pi(np.asarray(a) - np.asarray(b))) <= tol)


# What each sentence carries: formatter -> [(truth column, decoded value fn, tolerance)].
NMEA_FIELDS = {
    "GGA": [("lat", lambda m: m.latitude, 1e-5 / 60), ("lon", lambda m: m.longitude, 1e-5 / 60)],
    "VTG": [("sog", lambda m: float(m.spd_over_grnd_kts) * KNOT, 0.0006 * KNOT),
            ("cog", lambda m: np.radians(float(m.true_track)), np.radians(0.006))],
    "HDT": [("heading", lambda m: np.radians(float(m.heading)), np.radians(0.006))],
    "ROT": [("r", lambda m: np.radians(float(m.rate_of_turn)) / 60, np.radians(0.006) / 60)],
    "VBW": [("stw_long", lambda m: float(m.lon_water_spd) * KNOT, 0.0006 * KNOT),
            ("stw_trans", lambda m: float(m.trans_water_spd) * KNOT, 0.0006 * KNOT),
            ("u", lambda m: float(m.lon_grnd_spd) * KNOT, 0.0006 * KNOT),
            ("v", lambda m: float(m.trans_grnd_spd) * KNOT, 0.0006 * KNOT)],
    "VDR": [("current_set", lambda m: np.radians(float(m.deg_t)), np.radians(0.06)),
            ("current_drift", lambda m: float(m.current) * KNOT, 0.006 * KNOT)],
    "DPT": [("depth_below_transducer", lambda m: float(m.depth), 0.006)],
}
ANGLES = {"cog", "heading", "current_set"}


def _run_chunks(name: str, duration: float):
    sim = Simulation(SCENARIOS[name], seed=7, duration=duration, ideal=True)
    for chunk in sim.chunks(30.0):
        yield sim, chunk


@pytest.mark.parametrize("name", ["stw-cross-current", "manoeuvre-zigzag-north"])
def test_nmea_sentences_parse_and_equal_truth(name: str) -> None:
    seen = defaultdict(int)
    for sim, chunk in _run_chunks(name, 60.0 if name.startswith("manoeuvre") else 1300.0):
        epoch = sim.scenario.start_epoch
        rows = defaultdict(list)
        for line in nmea_lines(chunk.nmea):
            m = TAG.match(line)
            assert m, line
            tag_body = line[1:line.index("*")]
            assert int(m.group(2), 16) == _xor(tag_body)
            msg = pynmea2.parse(m.group(3), check=True)
            rows[msg.sentence_type].append((float(m.group(1)) - epoch, msg))
        for kind, items in rows.items():
            t = np.array([x[0] for x in items])
            truth = sim.truth.sample(t)
            for column, get, tol in NMEA_FIELDS.get(kind, []):
                got = np.array([get(x[1]) for x in items], dtype=float)
                if column in ANGLES:
                    assert _angle_close(got, truth[column], tol), (kind, column)
                else:
                    np.testing.assert_allclose(got, truth[column], atol=tol, rtol=0, err_msg=f"{kind} {column}")
            seen[kind] += len(items)
    assert {"GGA", "VTG", "HDT", "ROT", "VBW", "DPT", "ZDA"} <= set(seen)
    if name.startswith("stw"):
        assert seen["VDR"] == 2  # one forecast every 20 minutes


# PGN -> [(truth column, field id, tolerance)].
N2K_FIELDS = {
    127250: [("heading", "heading", 0.6e-4)],
    127251: [("r", "rate", 2e-8)],
    127257: [("heading", "yaw", 0.6e-4), ("pitch", "pitch", 0.6e-4), ("roll", "roll", 0.6e-4)],
    129025: [("lat", "latitude", 0.6e-7), ("lon", "longitude", 0.6e-7)],
    129026: [("cog", "cog", 0.6e-4), ("sog", "sog", 0.006)],
    129029: [("lat", "latitude", 1e-12), ("lon", "longitude", 1e-12)],
}


def test_can_frames_decode_and_equal_truth(dbc_db) -> None:
    """NMEA 2000 through nmea2000 (canboat definitions, fast-packet reassembly), DBC
    frames through cantools, all against the truth; draft counters count per mark."""
    decoder = NMEA2000Decoder()
    seen = defaultdict(int)
    counters = defaultdict(list)
    for sim, chunk in _run_chunks("draft-squat", 60.0):
        epoch = sim.scenario.start_epoch
        values = defaultdict(list)
        for line in candump_lines(chunk.can, "can0"):
            m = CANDUMP.match(line)
            assert m, line
            t = float(m.group(1)) - epoch
            fid, data = int(m.group(2), 16), bytes.fromhex(m.group(3))
            if len(m.group(2)) == 3:
                msg = dbc_db.get_message_by_frame_id(fid)
                assert len(data) == msg.length
                decoded = msg.decode(data, decode_choices=False)
                values[msg.name if fid not in DRAFT_IDS.values() else fid].append((t, decoded))
                if fid in DRAFT_IDS.values():
                    counters[fid].append(decoded["counter"])
                continue
            out = decoder.decode(line)
            if out is None:
                continue  # a fast-packet frame before the last
            fields = {f.id: f.value for f in out.fields}
            if out.PGN == 129029:
                t = round(t - 6 * 0.0005, 3)  # completed by its 7th frame, sampled at its 1st
            values[out.PGN].append((t, fields))
        for key, items in values.items():
            t = np.array([x[0] for x in items])
            truth = sim.truth.sample(t)
            seen[key] += len(items)
            if key in N2K_FIELDS:
                for column, field, tol in N2K_FIELDS[key]:
                    got = np.array([x[1][field] for x in items], dtype=float)
                    if column in ANGLES:
                        assert _angle_close(got, truth[column], tol), (key, column)
                    else:
                        np.testing.assert_allclose(got, truth[column], atol=tol, rtol=0, err_msg=f"{key} {column}")
            elif isinstance(key, int):  # a draft mark
                mark = next(n for n, i in DRAFT_IDS.items() if i == key)
                got = np.array([x[1]["draft"] for x in items])
                np.testing.assert_allclose(got, truth[f"draft_{mark}"], atol=0.0006, rtol=0)
            else:
                signals = {"ImuAccel": [("ax", "ax"), ("ay", "ay"), ("az", "az")],
                           "ImuRate": [("r", "yaw_rate"), ("roll_rate", "roll_rate"), ("pitch_rate", "pitch_rate")],
                           "ImuAttitude": [("roll", "roll"), ("pitch", "pitch"), ("heave", "heave")]}[key]
                for column, sig in signals:
                    got = np.array([x[1][sig] for x in items])
                    step = dbc_db.get_message_by_name(key).get_signal_by_name(sig).scale
                    np.testing.assert_allclose(got, truth[column], atol=0.6 * step, rtol=0, err_msg=f"{key} {sig}")
    assert set(N2K_FIELDS) | {"ImuAccel", "ImuRate", "ImuAttitude"} <= set(seen)
    assert seen[129029] == 60 and seen[0x310] == 6000
    for fid, c in counters.items():
        assert np.all(np.diff(c) % 256 == 1), hex(fid)  # +1 per frame of that mark


def test_fast_packet_layout() -> None:
    """129029 is 43 bytes: 7 frames, sequence counter in the top 3 bits, length in frame 0."""
    payload = np.arange(43, dtype=np.uint8)[None, :]
    frames = n2k.fast_packet(payload, np.array([9]))
    assert frames.shape == (1, 7, 8)
    assert frames[0, 0, 0] == (9 % 8) << 5 and frames[0, 0, 1] == 43
    assert list(frames[0, 1, :2]) == [(1 << 5) | 1, 6]
    assert list(frames[0, 6, -3:]) == [0xFF] * 3  # 6 + 6·7 = 48 bytes: 5 of padding
    assert n2k.can_id(127250, 0x12, 2) == 0x09F11212


def test_checksums_of_a_batch_match_one_by_one() -> None:
    bodies = ["GPGGA,1,2", "HEHDT,0.00,T", "", "X"]
    assert nmea0183.checksums(bodies) == [f"{_xor(b):02X}" for b in bodies]
