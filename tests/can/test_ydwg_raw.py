"""Yacht Devices RAW logs (`hh:mm:ss.mmm R|T id xx …`): the real one, dates, round trip, bad lines.

Expected per-PGN counts are ../shared/data/INDEX.md's ("Key PGNs (messages)", #23),
counted independently of edged. Values were read by hand from the file's lines with
the NMEA 2000 layouts (little-endian; the identifier's bits 8-25 are the PGN, its low
byte the source).
"""

from __future__ import annotations

import io
import math
import struct
from pathlib import Path

import pytest

from edged.plugin import ReplayOptions
from edged_can import candump
from edged_can.formats import actisense_plain, can_id, ikonvert, ydwg_raw
from edged_can.logs import CANDUMP
from edged_can.plugin import CanInput

REAL = "canboat__samples__merrimac-ydwg-2020.raw"
COUNTS = {
    127250: 51, 127251: 51, 127257: 26, 127258: 18, 128259: 3, 128267: 10,
    129025: 91, 129026: 38, 129029: 9, 126992: 11,
}
DAY = 86400
#: 2020-03-04T00:00:00Z, the day PGN 126992 from source 45 states (days 0x4795 = 18325)
MERRIMAC_DAY = 18325 * DAY


def _decode(data: bytes | io.BufferedIOBase, health, date: str | None = None, source: str = "yd"):
    stream = io.BytesIO(data) if isinstance(data, bytes) else data
    decoder = CanInput.make_decoder(source, None, health)
    out = []
    for raw in ydwg_raw.read(stream, source, health, ReplayOptions(date=date)):
        assert raw.meta == {"format": "ydwg_raw"}
        out.extend(decoder.decode(raw))
    return out


def test_real_log_gives_the_index_counts(n2k_data, make_health):
    path = n2k_data / REAL
    assert ydwg_raw.sniff(path.read_bytes()[:4096])
    health = make_health("merrimac")
    with path.open("rb") as f:
        ms = _decode(f, health)
    c = health.counters
    for pgn, n in COUNTS.items():
        assert c.get(f"pgn.{pgn}", 0) == n, (pgn, c.get(f"pgn.{pgn}"))
    assert c["frames"] == 914  # every line (INDEX: 914 records, 0 unparsed)
    assert not [k for k in c if k.startswith("rejected.") and k not in ("rejected.no_fix",)]
    assert c.get("fastpacket.lost", 0) == 0
    # The date from the log: 2020-03-04, never 1970; the file spans 2.5 s.
    assert ms and all(MERRIMAC_DAY + 1798 <= m.t <= MERRIMAC_DAY + 1802 for m in ms)


def test_values_read_by_hand(n2k_data, make_health):
    with (n2k_data / REAL).open("rb") as f:
        ms = _decode(f, make_health("m"), source="m")

    def first(kind, source):
        return next(m for m in ms if m.kind == kind and m.source == source)

    # 00:29:58.627 R 09F11213 00 16 3A FF 7F FF 7F FD: PGN 0x1F112 = 127250 from 0x13 = 19;
    # heading 0x3A16 = 14870 × 1e-4 rad, deviation/variation 0x7FFF (none), reference
    # 0xFD & 3 = 1 magnetic, and no 127258 heard yet: a magnetic heading. This line
    # comes before the log's first date (00:29:59.000) and was held for it.
    hdg = first("heading_magnetic", "m.19")
    assert hdg.values["heading"] == pytest.approx(1.4870, abs=1e-9)
    assert hdg.t == pytest.approx(MERRIMAC_DAY + 29 * 60 + 58.627, abs=1e-6)
    # 00:29:58.626 R 0DF11313 00 9D F3 FC FF …: 127251, rate int32 0xFFFCF39D = -199779 × 3.125e-8 rad/s
    assert first("yaw_rate", "m.19").values["r"] == pytest.approx(-199779 * 3.125e-8, rel=1e-9)
    # 00:29:58.627 R 0DF11913 00 FF 7F 33 00 BE FF FF: 127257, yaw 0x7FFF, pitch 0x0033 = 51,
    # roll 0xFFBE = -66, × 1e-4 rad
    att = first("attitude", "m.19").values
    assert att["pitch"] == pytest.approx(0.0051, abs=1e-9) and att["roll"] == pytest.approx(-0.0066, abs=1e-9)
    # 00:29:58.703 R 09F8012D 68 4F B3 08 68 BC A0 DB: 129025 from 45, lat 0x08B34F68 =
    # 145969000, lon 0xDBA0BC68 = -610223000, × 1e-7 degrees
    pos = first("position", "m.45").values
    assert pos["lat"] == pytest.approx(14.5969, abs=1e-9) and pos["lon"] == pytest.approx(-61.0223, abs=1e-9)
    # 00:29:58.753 R 09F8022D 87 FF FF FF 06 00 FF FF: 129026, COG 0xFFFF (none), SOG 6 × 0.01 m/s
    assert first("velocity_ground", "m.45").values == {"sog": pytest.approx(0.06, abs=1e-9)}
    # 00:29:58.941 R 15F50B24 67 BC 01 00 00 F4 01 FF: 128267 from 0x24 = 36, depth 0x1BC =
    # 444 × 0.01 m, offset 0x01F4 = 500 × 0.001 m
    dep = first("depth", "m.36").values
    assert dep["depth"] == pytest.approx(4.44, abs=1e-9) and dep["offset"] == pytest.approx(0.5, abs=1e-9)
    # 00:29:58.943 R 09F50324 71 00 00 FF FF …: 128259, speed through water 0 × 0.01 m/s
    assert first("water_speed", "m.36").values["stw_long"] == 0.0


# ---- dates -------------------------------------------------------------------------


def _line(tod_ms: int, ident: int, data: bytes, rt: str = "R") -> bytes:
    tod_ms %= DAY * 1000
    s, ms = divmod(tod_ms, 1000)
    return f"{s // 3600:02d}:{s // 60 % 60:02d}:{s % 60:02d}.{ms:03d} {rt} {ident:08X} {data.hex(' ').upper()}\n".encode()


def _heading(tod_ms: int, heading: float = 1.0, src: int = 7, rt: str = "R") -> bytes:
    # 127250, true (reference 0): heading × 1e-4 rad
    return _line(tod_ms, can_id(2, 127250, src, 255), struct.pack("<BHhhB", 0, round(heading / 1e-4), 0x7FFF, 0x7FFF, 0xFC), rt)


def _system_time(tod_ms: int, days: int, secs: float, src: int = 3) -> bytes:
    # 126992: SID, source 0 (GPS), days since 1970, seconds since midnight × 1e-4
    return _line(tod_ms, can_id(3, 126992, src, 255), struct.pack("<BBHI", 0, 0xF0, days, round(secs * 1e4)))


def test_lines_before_the_first_date_are_held_and_released_with_it(make_health):
    log = _heading(43_200_000) + _heading(43_200_500) + _system_time(43_201_000, 19000, 43201.0) + _heading(43_201_500)
    health = make_health("h")
    ms = _decode(log, health)
    assert [m.t for m in ms] == pytest.approx([19000 * DAY + 43200.0, 19000 * DAY + 43200.5, 19000 * DAY + 43201.5], abs=1e-6)
    assert not [k for k in health.counters if k.startswith("rejected.")]


def test_the_date_of_a_system_time_from_just_before_midnight(make_health):
    # 126992 says 23:59:59.9 of day 19000, the gateway stamps it 00:00:00.100: the
    # line's time of day is nearest the next day's midnight, so it is day 19001.
    log = _system_time(100, 19000, 86399.9) + _heading(200)
    ms = _decode(log, make_health("h"))
    assert [m.t for m in ms] == pytest.approx([19001 * DAY + 0.2], abs=1e-6)


def test_a_129029_in_frames_dates_the_log(make_health, build):
    payload = build.pgn_129029(54.0, 7.0, days=19500, secs=3600.0)
    log = _heading(3_599_000)
    for i, fr in enumerate(build.fast_frames(payload)):
        log += _line(3_600_000 + i, can_id(3, 129029, 160, 255), fr)
    ms = _decode(log, make_health("h"))
    assert [m.kind for m in ms] == ["heading", "position"]
    assert [m.t for m in ms] == pytest.approx([19500 * DAY + 3599.0, 19500 * DAY + 3600.006], abs=1e-6)


def test_date_option_wins_over_the_logs_own(n2k_data, make_health):
    health = make_health("m")
    with (n2k_data / REAL).open("rb") as f:
        ms = _decode(f, health, date="2021-05-06")
    day = 18753 * DAY  # 2021-05-06
    assert health.counters["pgn.127250"] == 51
    assert ms and all(day + 1798 <= m.t <= day + 1802 for m in ms)


def test_no_date_anywhere_rejects_every_line_naming_date(make_health):
    log = b"".join(_heading(1000 * i) for i in range(50))
    health = make_health("h")
    assert _decode(log, health) == []
    assert health.counters["rejected.no_date"] == 50
    assert health.counters["errors"] == 1 and "--date" in health.last_error


def test_held_lines_are_bounded(make_health, monkeypatch):
    monkeypatch.setattr(ydwg_raw, "HOLD", 20)
    log = b"".join(_heading(1000 * i) for i in range(25)) + _system_time(25_000, 19000, 25.0)
    health = make_health("h")
    ms = _decode(log, health)
    assert health.counters["rejected.no_date"] == 5  # the five oldest
    assert [m.t for m in ms] == pytest.approx([19000 * DAY + i for i in range(5, 25)], abs=1e-6)


def test_midnight_rolls_the_date_over_once(make_health):
    t = [86_399_000, 86_399_950, 100, 86_399_980, 300, 43_200_000]
    # 23:59:59.000, 23:59:59.950, 00:00:00.100 (midnight), 23:59:59.980 (a late line
    # of the day before: jitter, not a second midnight), 00:00:00.300, 12:00:00.000
    health = make_health("h")
    ms = _decode(b"".join(_heading(x) for x in t), health, date="2024-01-01")
    d = 19723 * DAY  # 2024-01-01
    assert [m.t for m in ms] == pytest.approx([d + 86399.0, d + 86399.95, d + DAY + 0.1, d + 86399.98, d + DAY + 0.3,
                                           d + DAY + 43200.0], abs=1e-6)
    assert not [k for k in health.counters if k.startswith("rejected.")]


def test_transmitted_frames_are_bus_traffic_and_counted(make_health):
    health = make_health("h")
    ms = _decode(_heading(1000) + _heading(2000, rt="T") + _heading(3000), health, date="2024-01-01")
    assert [m.kind for m in ms] == ["heading"] * 3
    assert health.counters["frames.tx"] == 1 and health.counters["frames"] == 3


def test_a_clock_set_back_is_followed_after_ten_agreeing_lines(make_health):
    log = b"".join(_heading(3_600_000 + 100 * i) for i in range(3))
    log += b"".join(_heading(1_800_000 + 100 * i) for i in range(12))  # 01:00 -> 00:30
    health = make_health("h")
    ms = _decode(log, health, date="2024-01-01")
    assert health.counters["rejected.time_backwards"] == 9
    assert len(ms) == 3 + 3 and ms[3].t == pytest.approx(19723 * DAY + 1800.9, abs=1e-6)


# ---- round trip: candump and YDWG RAW of the same frames -----------------------------


def _frames(build, n: int = 3000):
    """(t, prio, pgn, src, dst, data): a 126992 first, then heading, rate of turn and
    129029 fast-packets (GNSS position), as senders put them on the bus."""
    t0 = 1_700_000_000  # 2023-11-14T22:13:20Z
    days, secs = divmod(t0, DAY)
    out = [(t0, 3, 126992, 3, 255, struct.pack("<BBHI", 0, 0xF0, days, secs * 10_000))]
    for i in range(n // 3):
        t = (t0 * 1000 + 100 * i + 1) / 1000.0  # whole milliseconds
        out.append((t, 2, 127250, 7, 255, struct.pack("<BHhhB", i & 0xFF, (i * 37) % 62831, 0x7FFF, 0x7FFF, 0xFC)))
        out.append((t + 0.01, 2, 127251, 7, 255, struct.pack("<BiBBB", i & 0xFF, 1000 * (i % 50 - 25), 0xFF, 0xFF, 0xFF)))
        if i % 10 == 0:
            payload = build.pgn_129029(54.0 + i * 1e-5, 7.0, days=days, secs=secs + 0.1 * i)
            for k, fr in enumerate(build.fast_frames(payload, seq=(i // 10) % 8)):
                out.append((t + 0.02 + 0.001 * k, 3, 129029, 160, 255, fr))
    return out


def test_round_trip_candump_and_ydwg_give_identical_measurements(make_health, build):
    frames = _frames(build)
    dump = b"".join(
        f"({t:.6f}) bus {can_id(p, pgn, s, d):08X}#{data.hex().upper()}\n".encode() for t, p, pgn, s, d, data in frames
    )
    yd = b"".join(_line(round(t * 1000), can_id(p, pgn, s, d), data) for t, p, pgn, s, d, data in frames)
    assert ydwg_raw.sniff(yd) and not candump.sniff(yd) and not actisense_plain.sniff(yd) and not ikonvert.sniff(yd)
    health = make_health("a")
    decoder = CanInput.make_decoder("bus", None, health)
    a = [m for raw in CANDUMP.open(io.BytesIO(dump), "bus", health, ReplayOptions()) for m in decoder.decode(raw)]
    b = _decode(yd, make_health("b"), source="bus")
    assert len(a) == 2 * 1000 + 100
    assert [(m.kind, m.source, round(m.t, 3), m.values, m.t_src) for m in a] == [
        (m.kind, m.source, round(m.t, 3), m.values, m.t_src) for m in b
    ]


# ---- bad lines -----------------------------------------------------------------------

GOOD = b"12:00:00.000 R 09F11207 00 10 27 FF 7F FF 7F FC\n"  # 127250 from 7, heading 1.0 rad, true
BAD = [
    (b"12:00:00.500 R 09F11207 00 10 27 FF 7F FF 7F FC 00\n", "rejected.bad_length"),  # 9 bytes
    (b"12:00:00.500 R 3FF11207 00 10 27 FF 7F FF 7F FC\n", "rejected.bad_id"),  # beyond 29 bits
    (b"12:00:00.500 R 1F1 00 10 27 FF 7F FF 7F FC\n", "rejected.bad_id"),  # not 8 digits
    (b"12:00:00.500 X 09F11207 00 10 27 FF 7F FF 7F FC\n", "rejected.bad_line"),  # neither R nor T
    (b"12:00:00.500 R 09F11207 00 1G 27 FF 7F FF 7F FC\n", "rejected.bad_line"),  # not hex
    (b"25:00:00.500 R 09F11207 00 10 27 FF 7F FF 7F FC\n", "rejected.bad_time"),  # no such hour
    (b"11:59:55.000 R 09F11207 00 10 27 FF 7F FF 7F FC\n", "rejected.time_backwards"),  # 5 s back
]


@pytest.mark.parametrize("line,counter", BAD)
def test_bad_lines_are_counted_and_the_rest_go_on(make_health, line, counter):
    health = make_health("bad")
    ms = _decode(GOOD + line + GOOD.replace(b"00.000", b"01.000"), health, date="2024-01-01")
    assert health.counters[counter] == 1
    assert [m.kind for m in ms] == ["heading", "heading"]
    assert all(math.isfinite(m.values["heading"]) and m.values["heading"] == pytest.approx(1.0) for m in ms)
    assert [m.t for m in ms] == pytest.approx([19723 * DAY + 43200.0, 19723 * DAY + 43201.0], abs=1e-6)


# ---- sniffing ------------------------------------------------------------------------


def test_sniff_claims_only_ydwg_logs(n2k_data):
    for path in sorted(Path(n2k_data).iterdir()):
        head = path.read_bytes()[:4096]
        assert ydwg_raw.sniff(head) == (path.name == REAL), path.name
    head = (n2k_data / REAL).read_bytes()[:4096]
    assert not candump.sniff(head) and not actisense_plain.sniff(head) and not ikonvert.sniff(head)
    gga = b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n"
    assert not ydwg_raw.sniff(gga) and not ydwg_raw.sniff(gga * 10)
