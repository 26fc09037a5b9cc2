"""candump lines that cannot be true (issue 10): times, identifiers, lengths and
interface names are rejected by reason, and one bad line costs only itself, in the
reader, in `edged replay --record` and at `--speed 100`."""

from __future__ import annotations

import os
import io
import math
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from edged.cli import main
from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.timecheck import CONFIRM, EARLIEST, LATEST
from edged_can import candump
from edged_can.logs import CANDUMP
from edged_can.plugin import CanInput

T0 = 1732350000.0
GOOD = [f"({T0 + i:.6f}) can0 {0x09F11201 + i:08X}#00112233445566{i:02X}" for i in range(4)]


def _health() -> ComponentHealth:
    return ComponentHealth("file", "input", "can", ManualClock(0.0))


def _read(text: bytes, health: ComponentHealth | None = None) -> tuple[list, ComponentHealth]:
    h = health or _health()
    return list(CANDUMP.open(io.BytesIO(text), "file", h, ReplayOptions())), h


def _with(bad: str) -> bytes:
    """The good log with `bad` in the middle."""
    return ("\n".join(GOOD[:2] + [bad] + GOOD[2:]) + "\n").encode("latin-1")


def _good_times(recs: list) -> list[float]:
    return [r.t for r in recs]


@pytest.mark.parametrize("stamp", ["inf", "-inf", "nan", "-1", "1e300", "20000000000.0", "1e9", "+1732350001.0"])
def test_a_time_that_cannot_be_true_costs_its_line_only(stamp):
    recs, h = _read(_with(f"({stamp}) can0 09F11201#0011223344556677"))
    assert _good_times(recs) == [T0, T0 + 1, T0 + 2, T0 + 3]
    assert h.counters["rejected.bad_time"] == 1
    assert "rejected.bad_line" not in h.counters


def test_relative_times_of_candump_t_z_are_kept():
    recs, h = _read(b"(000.000000) can0 123#01\n(000.250000) can0 123#02\n")
    assert [r.t for r in recs] == [0.0, 0.25] and "rejected.bad_time" not in h.counters


def test_a_time_more_than_a_day_after_the_newest_is_rejected():
    recs, h = _read(_with(f"({T0 + 2 * 86400:.6f}) can0 123#00"))
    assert _good_times(recs) == [T0, T0 + 1, T0 + 2, T0 + 3] and h.counters["rejected.bad_time"] == 1


def test_a_log_that_truly_jumps_a_week_ahead_loses_only_the_confirming_lines():
    week = [f"({T0 + 7 * 86400 + i:.6f}) can0 123#{i:02X}" for i in range(20)]
    recs, h = _read(("\n".join(GOOD + week) + "\n").encode())
    assert len(recs) == 4 + 20 - (CONFIRM - 1)
    assert recs[4].t == T0 + 7 * 86400 + CONFIRM - 1
    assert h.counters["rejected.bad_time"] == CONFIRM - 1


@pytest.mark.parametrize("ident", ["-12", "+12", "1_2", "0x123", "-0", "+7FF"])
def test_identifiers_python_would_take_are_rejected(ident):
    for line in (f"({T0 + 1.5:.6f}) can0 {ident}#00", f"({T0 + 1.5:.6f}) can0 {ident}   [1]  00"):
        recs, h = _read(_with(line))
        assert _good_times(recs) == [T0, T0 + 1, T0 + 2, T0 + 3], line
        assert h.counters["rejected.bad_id"] == 1, line


@pytest.mark.parametrize(
    "frame",
    [
        "123#000102030405060708",  # classic, 9 bytes
        "123##1" + "00" * 65,  # FD, longer than 64
        "123##1" + "00" * 9,  # FD, not an FD length
        "123##1" + "00" * 200,
    ],
)
def test_impossible_lengths_are_rejected(frame):
    recs, h = _read(_with(f"({T0 + 1.5:.6f}) can0 {frame}"))
    assert _good_times(recs) == [T0, T0 + 1, T0 + 2, T0 + 3]
    assert h.counters["rejected.bad_length"] == 1


def test_fd_lengths_are_kept():
    recs, h = _read(b"".join(b"(%f) can0 123##1%s\n" % (T0 + n, b"AB" * n) for n in (12, 16, 20, 24, 32, 48, 64)))
    assert [len(r.data) for r in recs] == [12, 16, 20, 24, 32, 48, 64] and h.counters.get("errors", 0) == 0


@pytest.mark.parametrize("screen", ["[9]  " + "00 " * 9, "[65]  " + "00 " * 65, "[13]  " + "00 " * 13])
def test_impossible_lengths_in_screen_output_are_rejected(screen):
    recs, h = _read(_with(f"({T0 + 1.5:.6f})  can0  123   {screen}"))
    assert _good_times(recs) == [T0, T0 + 1, T0 + 2, T0 + 3] and h.counters["rejected.bad_length"] == 1


@pytest.mark.parametrize("iface", [b"can\xc3\xa40", b"can\x010", b"can\x7f0", b"can/0", b"c" * 16])
def test_an_interface_name_that_is_not_one_makes_no_new_source(iface):
    text = _with("X").replace(b"X", b"(%f) %s 123#00" % (T0 + 1.5, iface))
    recs, h = _read(text)
    assert {r.source for r in recs} == {"can0"}
    assert h.counters["rejected.bad_interface"] == 1


# ---- through the CLI -------------------------------------------------------------
def _log(tmp_path: Path, bad: str) -> Path:
    path = tmp_path / "bus.log"
    path.write_bytes(_with(bad))
    return path


def test_replay_record_of_a_log_with_a_year_2603_line_records_every_other_line(tmp_path, capsys):
    from edged_mcap.rawreader import read_raw

    log = _log(tmp_path, "(20000000000.0) can0 09F11201#0011223344556677")
    out = tmp_path / "out.mcap"
    rc = main(["replay", str(log), "--no-zenoh", "--no-progress", "--record", str(out)])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "replayed 4 records, 3.0 s of data" in text
    with out.open("rb") as f:
        back = list(read_raw(f, _health(), out))
    assert [r.t for r in back] == [T0, T0 + 1, T0 + 2, T0 + 3]


@pytest.mark.parametrize("stamp", ["20000000000.0", "inf", "1e300"])
def test_replay_at_speed_100_with_a_bad_time_does_not_hang(tmp_path, stamp):
    log = _log(tmp_path, f"({stamp}) can0 09F11201#0011223344556677")
    proc = subprocess.run(
        [sys.executable, "-m", "edged.cli", "replay", str(log), "--no-zenoh", "--no-progress", "--speed", "100"],
        capture_output=True, text=True, timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    assert "replayed 4 records" in proc.stdout


# ---- property: whatever the line --------------------------------------------------
_tokens = st.sampled_from(
    ["(", ")", "#", "##", "[", "]", " ", "  ", "can0", "vcan1", "R", "-", "+", "_", "0x", "e", ".", "<0x", ">",
     "inf", "nan", "1e300", "20000000000.0", "1732350000.5", "0", "7FF", "800", "1FFFFFFF", "20000004",
     "09F11201", "00", "FF", "AB", "1", "8", "9", "12", "64", "65", "remote", "\x00", "\xe4", "\t"]
)
_lines = st.one_of(
    st.lists(_tokens, max_size=30).map("".join).map(lambda s: s.encode("latin-1")),
    st.binary(max_size=120),
    st.builds(
        lambda t, ident, data, fd: b"(%s) can0 %s#%s%s" % (t, ident, b"#1" if fd else b"", data),
        st.one_of(st.floats().map(lambda x: repr(x).encode()), st.sampled_from([b"1732350000.25", b"0.5", b"-1"])),
        st.one_of(st.text("0123456789ABCDEFabcdef_+-x ", max_size=10).map(str.encode), st.sampled_from([b"123", b"09F11201"])),
        st.binary(max_size=70).map(lambda b: b.hex().encode()),
        st.booleans(),
    ),
)
_FD = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64}


@settings(max_examples=int(os.environ.get("EDGED_FUZZ_EXAMPLES", "400")), deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(_lines, max_size=12))
def test_whatever_the_lines_every_record_is_sound(lines):
    h = _health()
    recs = list(candump.read(io.BytesIO(b"\n".join(lines)), "file", h, bus_from_line=True))
    newest = None
    for r in recs:
        assert isinstance(r.t, float) and math.isfinite(r.t)
        assert 0.0 <= r.t <= LATEST
        if r.t >= EARLIEST:
            # more than a day ahead only after CONFIRM - 1 rejected lines agreeing on it
            assert newest is None or r.t <= newest + 86400.0 or h.counters["rejected.bad_time"] >= CONFIRM - 1
            newest = r.t if newest is None else max(newest, r.t)
        can_id, ext = r.meta["id"], r.meta["ext"]
        assert 0 <= can_id < (1 << 29 if ext else 1 << 11)
        assert len(r.data) in _FD
        assert r.source == "file" or (r.source.isascii() and r.source.isprintable() and "/" not in r.source)


def test_the_fast_path_and_the_general_path_agree():
    lines = [f"({T0 + i / 8:.6f}) can0 {ident}#{data}" for i, (ident, data) in enumerate(
        [("09F11201", "0011223344556677"), ("123", ""), ("7FF", "01"), ("1FFFFFFF", "AABB"), ("800", "00"),
         ("20000004", "0004000000000000"), ("123", "R"), ("00000123", "0102")]
    )]
    fast, h1 = _read(("\n".join(lines) + "\n").encode())
    slow, h2 = _read(("\n".join(" " + line + " " for line in lines) + "\n").encode())  # padded: general path
    assert fast == slow and h1.counters == h2.counters
    assert [(r.meta["id"], r.meta["ext"]) for r in fast] == [(0x09F11201, True), (0x123, False), (0x7FF, False),
                                                             (0x1FFFFFFF, True), (0x123, True)]


def test_many_bad_lines_are_counted_and_logged_once_per_reason():
    bad = [f"({t}) can0 123#00" for t in ("inf", "nan", "-1") * 100] + [f"({T0:.6f}) can0 +12#00"] * 50
    recs, h = _read(("\n".join(GOOD + bad) + "\n").encode())
    assert len(recs) == 4
    assert (h.counters["rejected.bad_time"], h.counters["rejected.bad_id"]) == (300, 50)
    assert h.counters["errors"] == 2


def test_an_fd_frame_is_marked_fd_for_the_decoder_and_a_classic_one_is_not():
    recs, h = _read(
        b"(1732350000.000000) can0 123##1" + b"11" * 12 + b"\n"
        b"(1732350000.100000) can0 124#1122\n"
    )
    assert [r.meta.get("fd", False) for r in recs] == [True, False]
    dec = CanInput.make_decoder("can0", None, h)
    dec.decode(recs[0])
    assert "rejected.bad_length" not in h.counters  # 12 bytes is a valid FD length
