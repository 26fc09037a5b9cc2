"""NMEA 0183 logs with times that cannot be true, and noisy heads (issue 10).

A TAG or epoch time outside the plausible window (edged.timecheck) costs its line
only (`rejected.bad_time`), in the reader, in `edged replay --record` and at
`--speed 100`; a log whose first lines have bad checksums is still recognised."""

from __future__ import annotations

import os
import io
import subprocess
import sys
from functools import reduce
from operator import xor
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from edged.cli import main
from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.timecheck import LATEST
from edged_nmea0183.logs import NMEA0183

T0 = 1732350000.0


def _cs(body: str) -> str:
    return "%02X" % reduce(xor, body.encode(), 0)


def _tag(body: str) -> str:
    return f"\\{body}*{_cs(body)}\\"


def _hdt(heading: float) -> str:
    body = f"HEHDT,{heading:.1f},T"
    return f"${body}*{_cs(body)}"


def _good(i: int) -> str:
    return _tag(f"c:{int(T0) + i}") + _hdt(10.0 + i)


def _with(bad: str) -> bytes:
    return ("\r\n".join([_good(0), _good(1), bad, _good(2), _good(3)]) + "\r\n").encode()


def _health() -> ComponentHealth:
    return ComponentHealth("log", "input", "nmea0183", ManualClock(0.0))


def _read(data: bytes) -> tuple[list, ComponentHealth]:
    h = _health()
    return list(NMEA0183.open(io.BytesIO(data), "log", h, ReplayOptions())), h


def test_the_issue_s_tag_block_has_a_correct_checksum():
    assert _tag("c:20000000000") == "\\c:20000000000*6B\\"


BAD_TIMES = [
    _tag("c:20000000000") + _hdt(99.0),  # year 2603
    _tag("c:1e300") + _hdt(99.0),
    _tag("c:1e15") + _hdt(99.0),  # milliseconds, still year 33658
    _tag("c:100") + _hdt(99.0),  # 1970
    _tag(f"c:{int(T0) + 2 * 86400}") + _hdt(99.0),  # two days after the newest good time
    f"20000000000 {_hdt(99.0)}",  # epoch prefix
    f"{int(T0) + 3 * 86400}.5 {_hdt(99.0)}",
]


@pytest.mark.parametrize("bad", BAD_TIMES)
def test_a_time_that_cannot_be_true_costs_its_line_only(bad):
    recs, h = _read(_with(bad))
    assert [r.t for r in recs] == [T0, T0 + 1, T0 + 2, T0 + 3]
    assert [r.data for r in recs] == [_hdt(10.0 + i).encode() for i in range(4)]
    c = h.counters
    assert c["rejected.bad_time"] == 1
    assert c["lines"] == c["accepted"] + sum(v for k, v in c.items() if k.startswith("rejected."))


def test_a_log_that_truly_jumps_a_week_ahead_loses_only_the_confirming_lines():
    from edged.timecheck import CONFIRM

    week = [_tag(f"c:{int(T0) + 7 * 86400 + i}") + _hdt(float(i)) for i in range(20)]
    recs, h = _read(("\r\n".join([_good(0), _good(1)] + week) + "\r\n").encode())
    assert [r.t for r in recs] == [T0, T0 + 1] + [T0 + 7 * 86400 + i for i in range(CONFIRM - 1, 20)]
    assert h.counters["rejected.bad_time"] == CONFIRM - 1


def test_an_untagged_line_after_a_rejected_time_keeps_the_log_s_time():
    gga = "GPGGA,120001,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"
    rmc = "GPRMC,120000,A,4807.038,N,01131.000,E,022.4,084.4,231124,003.1,W"
    text = "\r\n".join([f"${rmc}*{_cs(rmc)}", _tag("c:20000000000") + _hdt(1.0), f"${gga}*{_cs(gga)}", _hdt(2.0)])
    recs, h = _read(text.encode() + b"\r\n")
    day = 1732320000.0  # 2024-11-23T00:00Z
    assert [r.t for r in recs] == [day + 43200.0, day + 43201.0, day + 43201.0]
    assert h.counters["rejected.bad_time"] == 1


def _s(body: str) -> str:
    return f"${body}*{_cs(body)}"


def test_an_rmc_date_decades_ahead_costs_its_line_only():
    rmc = "GPRMC,{},A,4807.038,N,01131.000,E,022.4,084.4,{},003.1,W"
    lines = [
        _s(rmc.format("120000", "231124")), _hdt(1.0),
        _s(rmc.format("120001", "230179")),  # 2079
        _hdt(2.0),
        _s("GPGGA,120002,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"), _hdt(3.0),
    ]
    recs, h = _read(("\r\n".join(lines) + "\r\n").encode())
    noon = 1732320000.0 + 43200.0
    assert [r.t for r in recs] == [noon, noon, noon, noon + 2, noon + 2]
    assert h.counters["rejected.bad_time"] == 1


def test_a_zda_date_one_day_ahead_is_still_taken():
    recs, h = _read(("\r\n".join([
        _s("GPRMC,235959,A,4807.038,N,01131.000,E,022.4,084.4,231124,003.1,W"),
        _s("GPZDA,000001.00,24,11,2024,00,00"),
    ]) + "\r\n").encode())
    assert [r.t for r in recs] == [1732406399.0, 1732406401.0] and "rejected.bad_time" not in h.counters


@pytest.mark.parametrize("fields", ["+24,11,2079", " 24,11,2079", "24,1_1,2079", "24,11,2_079"])
def test_zda_date_fields_python_would_take_are_not_a_date(fields):
    from edged_nmea0183.timeofday import sentence_time

    tod, day = sentence_time(_s(f"GPZDA,120000.00,{fields},00,00").encode())
    assert tod == 43200.0 and day is None


@pytest.mark.parametrize("tod", ["123519e3", "123519.5_5", "123519 ", "123519.", "123519.x"])
def test_times_of_day_float_would_take_are_refused(tod):
    from edged_nmea0183.timeofday import parse_tod

    assert parse_tod(tod) is None or tod == "123519."


def test_plain_times_of_day_still_parse():
    from edged_nmea0183.timeofday import parse_tod

    assert parse_tod("123519") == 45319.0 and parse_tod("123519.25") == 45319.25 and parse_tod("123519.") == 45319.0


# ---- through the CLI -------------------------------------------------------------
def _log(tmp_path: Path, bad: str) -> Path:
    path = tmp_path / "gyro.nmea"
    path.write_bytes(_with(bad))
    return path


def test_replay_record_of_a_log_with_a_year_2603_line_records_every_other_line(tmp_path, capsys):
    from edged_mcap.rawreader import read_raw

    log = _log(tmp_path, "\\c:20000000000*6B\\" + _hdt(99.0))
    out = tmp_path / "out.mcap"
    rc = main(["replay", str(log), "--no-zenoh", "--no-progress", "--record", str(out)])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "replayed 4 records, 3.0 s of data" in text
    assert "rejected.bad_time" in text
    with out.open("rb") as f:
        back = list(read_raw(f, _health(), out))
    assert [(r.t, r.data) for r in back] == [(T0 + i, _hdt(10.0 + i).encode()) for i in range(4)]


@pytest.mark.parametrize("bad", ["\\c:20000000000*6B\\", _tag("c:1e300")])
def test_replay_at_speed_100_with_a_bad_time_does_not_hang(tmp_path, bad):
    log = _log(tmp_path, bad + _hdt(99.0))
    proc = subprocess.run(
        [sys.executable, "-m", "edged.cli", "replay", str(log), "--no-zenoh", "--no-progress", "--speed", "100"],
        capture_output=True, text=True, timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    assert "replayed 4 records" in proc.stdout


# ---- detection past a noisy head ------------------------------------------------
def _noisy_log(n_bad: int, n_good: int) -> bytes:
    bad = [f"$HEHDT,{i % 360}.0,T*00" for i in range(n_bad)]  # wrong checksums
    good = [f"{int(T0) + i // 10}.{i % 10} {_hdt((i * 0.1) % 360)}" for i in range(n_good)]
    return ("\r\n".join(bad + good) + "\r\n").encode()


def test_bad_checksums_at_the_head_do_not_make_the_log_unrecognised(tmp_path, capsys):
    data = _noisy_log(21, 10_000 - 21)
    assert NMEA0183.sniff(data[:4096])
    path = tmp_path / "noisy.nmea"
    path.write_bytes(data)
    rc = main(["replay", str(path), "--no-zenoh", "--no-progress"])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert f"replayed {10_000 - 21} records" in out.out


def test_line_noise_filling_the_first_4_kib_does_not_hide_a_good_log(tmp_path, capsys):
    noise = b"".join(b"%03d \x00\xfe\x7f garbage of a port at the wrong baud rate\r\n" % i for i in range(120))
    assert len(noise) > 4096
    path = tmp_path / "noisy.nmea"
    path.write_bytes(noise + _noisy_log(0, 2000))
    rc = main(["replay", str(path), "--no-zenoh", "--no-progress"])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert "replayed 2000 records" in out.out


@pytest.mark.parametrize(
    "head",
    [
        b"Dear diary,\nthe wind was $5 worth today.\nNo NMEA here.\n" * 20,
        b"(1732350000.123456) can0 09F11201#0011223344556677\n" * 40,
        b"\x89MCAP0\r\n" + bytes(range(256)) * 8,
        b"".join(b"!PDGY,127250,2,3,255,481.%03d,2C20AAAAAAE=\r\n" % i for i in range(60)),
    ],
)
def test_foreign_formats_are_still_refused(head):
    assert not NMEA0183.sniff(head[:4096])


# ---- property: whatever the TAG times -------------------------------------------
_c_values = st.one_of(
    st.floats().map(repr),
    st.integers(-(10**20), 10**20).map(str),
    st.sampled_from(["20000000000", "1e300", "inf", "nan", "-1", "0", "1732350000.5", "1732350000500"]),
)


@settings(max_examples=int(os.environ.get("EDGED_FUZZ_EXAMPLES", "300")), deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(_c_values, st.booleans()), max_size=25))
def test_whatever_the_tag_times_every_record_time_is_finite_and_representable(items):
    lines = [(_tag(f"c:{c}") if tagged else f"{c} ") + _hdt(1.0) for c, tagged in items]
    recs, h = _read(("\r\n".join(lines) + "\r\n").encode())
    for r in recs:
        assert 0.0 <= r.t <= LATEST
    c = h.counters
    assert c.get("lines", 0) == c.get("accepted", 0) + sum(v for k, v in c.items() if k.startswith("rejected."))
