"""Issue 10, "Values that cannot be true pass": NMEA 2000 values beyond their range are
rejected (never wrapped), a bad variation is rejected by itself, GNSS methods and
times of day that are not values are not used, and frames longer than CAN allows are
rejected before any decoding.

The property-based part feeds random payloads to every PGN the decoder handles,
single-frame and fast-packet, and asserts that whatever is emitted is valid, finite,
with angles in [0, 2π) and never −0.0. Its example count is EDGED_FUZZ_EXAMPLES
(default 200; tests/bench/bench_fuzz.py runs 20,000).
"""

from __future__ import annotations

import math
import os
import struct

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from true_values import assert_true_values
from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.records import RawRecord
from edged_can import n2k_codec
from edged_can.config import CanConfig
from edged_can.decoder import CanDecoder

EXAMPLES = int(os.environ.get("EDGED_FUZZ_EXAMPLES", "200"))
FUZZ = settings(
    max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
RAD = 1e-4  # canboat's resolution of 16-bit angles


def _cog_sog(cog_raw: int, ref: int = 0, sog_raw: int = 515) -> bytes:
    return struct.pack("<BBHHH", 0, 0xFC | ref, cog_raw, sog_raw, 0xFFFF)


def _variation(var_raw: int) -> bytes:
    return struct.pack("<BBHhH", 0, 0xF1, 0xFFFF, var_raw, 0xFFFF)


def _heading_raw(raw: int, ref: int = 0, dev: int = 0x7FFF, var: int = 0x7FFF) -> bytes:
    return struct.pack("<BHhhB", 0, raw, dev, var, 0xFC | ref)


# ---- item 1: angles beyond 2π are not values ---------------------------------------

@pytest.mark.parametrize("raw", [0xFFFC, 62833, 65000])
@pytest.mark.parametrize("ref", [0, 1])
def test_heading_above_two_pi_is_rejected_not_wrapped(feed, health, build, raw, ref):
    assert feed((build.n2k_id(127250, 28), _heading_raw(raw, ref, var=round(math.radians(5) / RAD)))) == []
    assert health.counters["rejected.invalid_value"] == 1
    assert "measurements.heading" not in health.counters


def test_heading_just_below_two_pi_is_kept(feed, build):
    (m,) = feed((build.n2k_id(127250, 28), _heading_raw(62831)))
    assert m.values["heading"] == pytest.approx(6.2831)


def test_a_heading_of_360_degrees_quantised_upward_is_north(feed, build):
    """62832 counts (6.2832 rad, one count above 2π) is what a sensor reading 359.999°
    sends: north, not an impossible value."""
    (m,) = feed((build.n2k_id(127250, 28), _heading_raw(62832)))
    assert m.values["heading"] == 0.0


def test_heading_zero_is_positive_zero(feed, build):
    (m,) = feed((build.n2k_id(127250, 28), _heading_raw(0)))
    assert m.values["heading"] == 0.0 and math.copysign(1.0, m.values["heading"]) == 1.0
    # magnetic 10° with variation −10° in the same PGN: a sum that is exactly zero
    ten = round(math.radians(10) / RAD)
    (m,) = feed((build.n2k_id(127250, 28), _heading_raw(ten, 1, var=-ten)))
    assert m.kind == "heading" and math.copysign(1.0, m.values["heading"]) == 1.0


@pytest.mark.parametrize("ref", [0, 1])
def test_cog_above_two_pi_is_rejected(make_decoder, health, build, ref):
    dec = make_decoder(magnetic_variation_deg=2.0)
    assert dec.decode(build.raw(build.n2k_id(129026, 3), _cog_sog(0xFFFC, ref))) == []
    assert health.counters["rejected.invalid_value"] == 1


def test_magnetic_heading_deviation_beyond_pi_is_rejected(feed, health, build):
    assert feed((build.n2k_id(127250, 28), _heading_raw(1000, 1, dev=32000))) == []
    assert health.counters["rejected.invalid_value"] == 1


# ---- item 2: a bad variation is rejected by itself ---------------------------------

def test_variation_beyond_pi_is_rejected_and_the_last_good_kept(make_decoder, health, build):
    dec = make_decoder(magnetic_variation_deg=-3.0)
    five = round(math.radians(5.0) / RAD)
    ten = round(math.radians(10.0) / RAD)
    feed = lambda pgn, data: dec.decode(build.raw(build.n2k_id(pgn, 40), data))  # noqa: E731
    feed(127258, _variation(five))
    assert feed(127258, _variation(32000)) == []  # 3.2 rad
    assert health.counters["rejected.invalid_value"] == 1
    (m,) = feed(127250, _heading_raw(ten, 1))
    assert m.kind == "heading" and m.values["heading"] == pytest.approx(math.radians(15.0), abs=2e-4)


def test_bad_variation_first_leaves_the_configured_one(make_decoder, health, build):
    dec = make_decoder(magnetic_variation_deg=-3.0)
    ten = round(math.radians(10.0) / RAD)
    dec.decode(build.raw(build.n2k_id(127258, 40), _variation(-32000)))
    (m,) = dec.decode(build.raw(build.n2k_id(127250, 28), _heading_raw(ten, 1)))
    assert m.values["heading"] == pytest.approx(math.radians(7.0), abs=2e-4)
    (v,) = dec.decode(build.raw(build.n2k_id(129026, 3), _cog_sog(ten, 1)))
    assert v.values["cog"] == pytest.approx(math.radians(7.0), abs=2e-4)


def test_bad_variation_in_127250_rejects_that_message_only(make_decoder, health, build):
    dec = make_decoder(magnetic_variation_deg=-3.0)
    ten = round(math.radians(10.0) / RAD)
    assert dec.decode(build.raw(build.n2k_id(127250, 28), _heading_raw(ten, 1, var=32000))) == []
    (m,) = dec.decode(build.raw(build.n2k_id(127250, 28), _heading_raw(ten, 1)))
    assert m.values["heading"] == pytest.approx(math.radians(7.0), abs=2e-4)


# ---- item 3: GNSS method, time of day ----------------------------------------------

def _gnss(feed, build, **kw):
    frames = build.fast_frames(build.pgn_129029(60.0, 20.0, **kw), seq=1)
    return feed(*[(build.n2k_id(129029, 21), f) for f in frames])


@pytest.mark.parametrize("method", [9, 10, 11, 12, 13])
def test_gnss_method_undefined_is_rejected(feed, health, build, method):
    assert _gnss(feed, build, method=method) == []
    assert health.counters["rejected.invalid_value"] == 1


def test_gnss_method_error_is_no_fix(feed, health, build):
    assert _gnss(feed, build, method=14) == []
    assert health.counters["rejected.no_fix"] == 1


def test_gnss_method_unavailable_is_no_fix_quality(feed, build):
    (m,) = _gnss(feed, build, method=15)
    assert "fix_quality" not in m.values and m.values["lat"] == pytest.approx(60.0)


def test_gnss_method_8_is_a_fix_quality(feed, build):
    (m,) = _gnss(feed, build, method=8)
    assert m.values["fix_quality"] == 8


def test_gnss_time_of_day_beyond_a_day_drops_t_src_keeps_position(feed, health, build):
    (m,) = _gnss(feed, build, secs=4 * 86400 + 3600.0)
    assert m.kind == "position" and m.t_src is None
    assert health.counters["rejected.bad_time_of_day"] == 1
    assert "86400" in health.last_error


def test_gnss_leap_second_is_a_time_of_day(feed, health, build):
    (m,) = _gnss(feed, build, secs=86400.5)
    assert m.t_src == pytest.approx(20000 * 86400 + 86400.5)
    assert "rejected.bad_time_of_day" not in health.counters


def test_system_time_beyond_a_day_is_rejected(feed, health, build):
    data = struct.pack("<BBHI", 0, 0xF0, 20000, round(4 * 86400 / 1e-4))
    assert feed(build.raw(build.n2k_id(126992, 20), data)) == []
    assert health.counters["rejected.bad_time_of_day"] == 1
    assert "clock_offset_s" not in health.info


# ---- item 4: frame lengths ---------------------------------------------------------

@pytest.mark.parametrize("n", [9, 15, 64, 200])
def test_n2k_frame_longer_than_8_is_rejected_before_decoding(feed, health, build, n):
    data = _heading_raw(1000).ljust(n, b"\xff")
    assert feed((build.n2k_id(127250, 28), data)) == []
    assert health.counters["rejected.bad_length"] == 1
    assert "pgn.127250" not in health.counters and "frames.n2k" not in health.counters


def test_n2k_frame_longer_than_8_is_rejected_even_marked_fd(decoder, health, build):
    raw = RawRecord("can", "can0", 1.0, _heading_raw(1000).ljust(12, b"\xff"),
                    {"id": build.n2k_id(127250, 28), "ext": True, "fd": True})
    assert decoder.decode(raw) == []
    assert health.counters["rejected.bad_length"] == 1


def test_fast_packet_frame_longer_than_8_is_rejected(feed, health, build):
    frames = build.fast_frames(build.pgn_129029(60.0, 20.0), seq=1)
    frames[1] = frames[1] + b"\x00" * 8
    assert feed(*[(build.n2k_id(129029, 21), f) for f in frames]) == []
    assert health.counters["rejected.bad_length"] == 1


def test_classic_dbc_frame_longer_than_8_is_rejected(decoder, health, build):
    data = struct.pack("<HBB", 1500, 0, 0).ljust(9, b"\x00")
    assert decoder.decode(build.raw(0x310, data, ext=False)) == []
    assert health.counters["rejected.bad_length"] == 1
    assert not any(k.startswith("dbc.") for k in health.counters)


def test_11_bit_unknown_frames_longer_than_allowed(decoder, health, build):
    assert decoder.decode(build.raw(0x123, bytes(9), ext=False)) == []
    fd = RawRecord("can", "can0", 1.0, bytes(64), {"id": 0x123, "ext": False, "fd": True})
    assert decoder.decode(fd) == []
    too_long = RawRecord("can", "can0", 1.0, bytes(65), {"id": 0x123, "ext": False, "fd": True})
    assert decoder.decode(too_long) == []
    c = health.counters
    assert c["rejected.bad_length"] == 2 and c["unknown_id.0x123"] == 1


def test_frames_of_8_bytes_still_decode(feed, health, build):
    (m,) = feed((build.n2k_id(127250, 28), _heading_raw(1000)))
    assert m.values["heading"] == pytest.approx(0.1)
    assert "rejected.bad_length" not in health.counters


# ---- item 5: property-based fuzzing of every handled PGN ---------------------------

SINGLE = (127250, 127251, 127257, 127258, 128259, 128267, 129025, 129026, 126992, 60928)
FAST = (129029,)
_BYTE = st.one_of(st.integers(0, 255), st.sampled_from([0x00, 0x7F, 0x80, 0xFC, 0xFD, 0xFE, 0xFF]))


def _fast_frames(payload: bytes, seq: int) -> list[bytes]:
    frames = [bytes([seq << 5, len(payload)]) + payload[:6]]
    rest, i = payload[6:], 1
    while rest:
        frames.append(bytes([(seq << 5) | i]) + rest[:7])
        rest, i = rest[7:], i + 1
    return [f.ljust(8, b"\xff") for f in frames]


def _n2k_id(pgn: int, src: int) -> int:
    if (pgn >> 8) & 0xFF < 240:
        pgn = (pgn & 0x3FF00) | 0xFF
    return (2 << 26) | (pgn << 8) | src


def _gnss_payload(method: int = 4, secs: float = 3600.0) -> bytes:
    return struct.pack(
        "<BHIqqqBBBhhiB",
        1, 20000, round(secs / 1e-4), round(60.5 / 1e-16), round(-20.25 / 1e-16), 0,
        (method << 4) | 0, 0xFC, 12, 80, 0x7FFF, 0, 0,
    )


#: A valid payload of every handled PGN, which the fuzzer mutates byte by byte (random
#: bytes alone would hardly ever make a valid reference or a whole 129029).
_TEMPLATES = {
    127250: _heading_raw(31416, 1, dev=100, var=-200),
    127251: struct.pack("<Bi", 0, 1000) + b"\xff" * 3,
    127257: struct.pack("<BhhhB", 0, 100, 200, 300, 0xFF),
    127258: _variation(500),
    128259: struct.pack("<BHHBB", 0, 612, 0xFFFF, 0, 0xFF) + b"\xff",
    128267: struct.pack("<BIhB", 0, 1234, -500, 0xFF),
    129025: struct.pack("<ii", round(-33.8688 / 1e-7), round(151.2093 / 1e-7)),
    129026: _cog_sog(10000, 0),
    126992: struct.pack("<BBHI", 0, 0xF0, 20000, 36_000_000),
    60928: bytes.fromhex("0123456789abcdef"),
    129029: _gnss_payload(),
}
assert set(_TEMPLATES) == set(SINGLE) | set(FAST)


@st.composite
def _payload(draw, pgn: int) -> bytes:
    if draw(st.integers(0, 4)) == 0:  # now and then, bytes that owe nothing to a template
        return bytes(draw(st.lists(_BYTE, max_size=60 if pgn in FAST else 8)))
    b = bytearray(_TEMPLATES[pgn])
    for i in range(len(b)):
        if draw(st.integers(0, 3)) == 0:
            b[i] = draw(_BYTE)
    return bytes(b[: draw(st.integers(max(0, len(b) - 3), len(b)))])


@st.composite
def _message(draw) -> list[tuple[int, bytes]]:
    """One message of a handled PGN with random payload bytes, as the frames it travels in."""
    src = draw(st.sampled_from([1, 28, 200]))
    pgn = draw(st.sampled_from(SINGLE + FAST))
    payload = draw(_payload(pgn))
    frames = _fast_frames(payload, draw(st.integers(0, 7))) if pgn in FAST else [payload]
    return [(_n2k_id(pgn, src), f) for f in frames]


_check_emitted = assert_true_values


_CONFIGS: dict[float | None, CanConfig] = {}


def _config(variation: float | None) -> CanConfig:
    """One configuration per variation (loading the reference DBC costs milliseconds)."""
    cfg = _CONFIGS.get(variation)
    if cfg is None:
        cfg = _CONFIGS[variation] = CanConfig.model_validate({"type": "can", "magnetic_variation_deg": variation})
    return cfg


def _check_against_canboat(frames: list[tuple[int, bytes]], ms) -> None:
    """Oracle: what is emitted from a message is what canboat decodes, never wrapped;
    a GNSS fix quality is a defined one and its time of day lies within a day."""
    if not ms:
        return
    can_id = frames[0][0]
    pgn = (can_id >> 8) & 0x3FFFF
    pgn = pgn & 0x3FF00 if (pgn >> 8) & 0xFF < 240 else pgn
    data = [d for _, d in frames]
    if pgn in FAST:
        payload = (data[0][2:8] + b"".join(d[1:8] for d in data[1:]))[: data[0][1]]
    else:
        payload = data[0]
    f = n2k_codec.decode_fields(pgn, payload, can_id & 0xFF, 255, 2)
    (m,) = ms
    if pgn == 127250 and f["reference"] == 0:
        assert m.values["heading"] == f["heading"], (f, m)
    if pgn == 129026 and f["cogReference"] == 0 and "cog" in m.values:
        assert m.values["cog"] == f["cog"], (f, m)
    if pgn == 129029:
        assert m.values.get("fix_quality", 1) in range(1, 9), (f, m)
        if m.t_src is not None:
            assert 0.0 <= m.t_src - f["date"] * 86400.0 < 86401.0, (f, m)


_E_HEADING = [(_n2k_id(127250, 28), _heading_raw(0xFFFC))]
_E_VARIATION = [[(_n2k_id(127258, 40), _variation(-32000))], [(_n2k_id(127250, 28), _heading_raw(1000, 1))]]
_E_GNSS = [(_n2k_id(129029, 21), f) for f in _fast_frames(_gnss_payload(method=9), 1)]
_E_GNSS_TIME = [(_n2k_id(129029, 21), f) for f in _fast_frames(_gnss_payload(secs=4 * 86400.0), 2)]


@FUZZ
@given(messages=st.lists(_message(), min_size=1, max_size=6), variation=st.sampled_from([None, -3.0, 179.0]))
@example(messages=[_E_HEADING, _E_GNSS, _E_GNSS_TIME], variation=None)
@example(messages=_E_VARIATION, variation=-3.0)
def test_fuzz_every_handled_pgn_emits_only_true_values(messages, variation):
    health = ComponentHealth("can0", "input", "can", ManualClock(1000.0))
    dec = CanDecoder("can0", _config(variation), health)
    for frames in messages:
        ms = []
        for can_id, data in frames:
            ms += dec.decode(RawRecord("can", "can0", 1000.0, data, {"id": can_id, "ext": True}))
        _check_emitted(ms)
        _check_against_canboat(frames, ms)
    v = dec._n2k._variation_pgn
    assert v is None or -math.pi <= v <= math.pi
