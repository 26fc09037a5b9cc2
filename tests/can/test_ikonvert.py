"""Digital Yacht iKonvert logs (`!PDGY,pgn,prio,src,dst,timer,base64`): the real one, time, round trip, bad lines.

Expected per-PGN counts are ../shared/data/INDEX.md's ("Key PGNs (messages)", #22),
counted independently of edged. Values were read by hand: the payload's base64
decoded (`base64 -d`), then the NMEA 2000 layouts (little-endian).
"""

from __future__ import annotations

import base64
import io
import math
import struct
from pathlib import Path

import pytest

from edged.plugin import ReplayOptions
from edged_can import candump
from edged_can.formats import Bad, actisense_plain, can_id, ikonvert, ydwg_raw
from edged_can.logs import CANDUMP
from edged_can.plugin import CanInput

REAL = "canboat__samples__ikonvert.log"
COUNTS = {127250: 2849, 127251: 2852, 129025: 286, 129026: 287, 129029: 287, 126992: 287}
DAY = 86400
# The log's first time: line 15, `!PDGY,126992,3,2,255,482.213,UACfRW74miM=` =
# 50 00 9f 45 6e f8 9a 23: days 0x459F = 17823 (2018-10-19), seconds 0x239AF86E =
# 597358702 × 1e-4 = 59735.8702 (16:35:35.870), at timer 482.213 s.
ANCHOR_MS = 17823 * DAY * 1000 + 59_735_870
ANCHOR_TIMER_MS = 482_213


def _decode(data: bytes | io.BufferedIOBase, health, date: str | None = None, source: str = "ik"):
    stream = io.BytesIO(data) if isinstance(data, bytes) else data
    decoder = CanInput.make_decoder(source, None, health)
    out = []
    for raw in ikonvert.read(stream, source, health, ReplayOptions(date=date)):
        assert raw.meta == {"format": "ikonvert"}
        out.extend(decoder.decode(raw))
    return out


def test_real_log_gives_the_index_counts(n2k_data, make_health):
    path = n2k_data / REAL
    data = path.read_bytes()
    assert ikonvert.sniff(data[:4096])
    health = make_health("ik")
    with path.open("rb") as f:
        ms = _decode(f, health)
    c = health.counters
    for pgn, n in COUNTS.items():
        assert c.get(f"pgn.{pgn}", 0) == n, (pgn, c.get(f"pgn.{pgn}"))
    # Every $PDGY sentence that starts a line or is glued to one that starts with a
    # sentence is the gateway's status (counted here independently of the reader).
    lines = [ln.strip() for ln in data.splitlines()]
    status = sum(ln.count(b"$PDGY") for ln in lines if ln.startswith((b"!PDGY,", b"$PDGY,")))
    assert c["gateway_status"] == status == 290
    assert c.get("timer_restarts", 0) == 0 and c.get("rejected.no_date", 0) == 0
    # 317 s of 2018-10-19 from 16:35:35, the timer's unpadded milliseconds read right:
    # in file order, time never goes back.
    ts = [m.t for m in ms]
    assert ts == sorted(ts)
    assert 17823 * DAY + 59735 <= ts[0] and ts[-1] - ts[0] == pytest.approx(316.8, abs=0.2)


def test_values_read_by_hand(n2k_data, make_health):
    with (n2k_data / REAL).open("rb") as f:
        ms = _decode(f, make_health("ik"), source="ik")
    # Line 2, `!PDGY,127250,2,3,255,481.734,2C20AAAAAAE=` = d8 2d b4 00 00 00 00 01:
    # heading 0xB42D = 46125 × 1e-4 rad, deviation 0, variation 0, reference 1
    # (magnetic): true heading 4.6125 + 0 + 0. Timer 481.734 s is 0.479 s before the
    # anchor's (this line was held until line 15 dated the log).
    hdg = next(m for m in ms if m.kind == "heading")
    assert hdg.source == "ik.3" and hdg.values["heading"] == pytest.approx(4.6125, abs=1e-9)
    assert hdg.t == pytest.approx((ANCHOR_MS + 481_734 - ANCHOR_TIMER_MS) / 1000, abs=1e-6)
    # Line 612, `!PDGY,127251,2,3,255,530.10,vxBi9v////8=` = bf 10 62 f6 ff ff ff ff:
    # rate int32 0xFFF66210 = -630256 × 3.125e-8 rad/s; timer `530.10` is 530 s 10 ms
    # (between the lines' 529.909 and 530.111).
    rot = [m for m in ms if m.kind == "yaw_rate" and m.values["r"] != 0.0]
    assert rot[1].values["r"] == pytest.approx(-630256 * 3.125e-8, rel=1e-9)
    assert rot[1].t == pytest.approx((ANCHOR_MS + 530_010 - ANCHOR_TIMER_MS) / 1000, abs=1e-6)
    assert rot[0].t < rot[1].t < rot[2].t


# ---- time ----------------------------------------------------------------------------


def _pdgy(pgn: int, timer_ms: int, payload: bytes, src: int = 7, prio: int = 2, dst: int = 255) -> bytes:
    # the gateway's timer: seconds, then milliseconds without zero padding
    return f"!PDGY,{pgn},{prio},{src},{dst},{timer_ms // 1000}.{timer_ms % 1000},{base64.b64encode(payload).decode()}\n".encode()


def _heading(timer_ms: int, heading: float = 1.0) -> bytes:
    return _pdgy(127250, timer_ms, struct.pack("<BHhhB", 0, round(heading / 1e-4), 0x7FFF, 0x7FFF, 0xFC))


def _system_time(timer_ms: int, days: int, secs: float) -> bytes:
    return _pdgy(126992, timer_ms, struct.pack("<BBHI", 0, 0xF0, days, round(secs * 1e4)), src=2, prio=3)


def test_the_first_system_time_dates_the_lines_before_and_after_it(make_health):
    log = _heading(10_000) + _heading(10_050) + _system_time(11_000, 19000, 43200.0) + _heading(12_005)
    health = make_health("ik")
    ms = _decode(log, health)
    d = 19000 * DAY
    assert [m.t for m in ms] == pytest.approx([d + 43199.0, d + 43199.05, d + 43201.005], abs=1e-6)
    assert not [k for k in health.counters if k.startswith("rejected.")]


def test_a_129029_dates_the_log(make_health, build):
    log = _heading(1_000) + _pdgy(129029, 2_000, build.pgn_129029(54.0, 7.0, days=19500, secs=7200.0), src=160)
    ms = _decode(log, make_health("ik"))
    assert [m.kind for m in ms] == ["heading", "position"]
    assert [m.t for m in ms] == pytest.approx([19500 * DAY + 7199.0, 19500 * DAY + 7200.0], abs=1e-6)
    assert ms[1].values["lat"] == pytest.approx(54.0)


def test_date_option_wins_with_the_logs_time_of_day(n2k_data, make_health):
    with (n2k_data / REAL).open("rb") as f:
        ms = _decode(f, make_health("ik"), date="2020-01-02")
    day = 18263 * DAY  # 2020-01-02; 16:35:35.363 from the log's first 126992 and timer
    assert ms[0].t == pytest.approx(day + (ANCHOR_MS % (DAY * 1000) + 481_734 - ANCHOR_TIMER_MS) / 1000, abs=1e-6)


def test_date_option_without_a_time_in_the_log_counts_the_timer_from_midnight(make_health):
    health = make_health("ik")
    ms = _decode(_heading(5_000) + _heading(3_605_250), health, date="2024-01-01")
    d = 19723 * DAY
    assert [m.t for m in ms] == pytest.approx([d + 5.0, d + 3605.25], abs=1e-6)
    assert not [k for k in health.counters if k.startswith("rejected.")]


def test_no_date_anywhere_rejects_every_line_naming_date(make_health):
    health = make_health("ik")
    assert _decode(b"".join(_heading(1000 * i) for i in range(40)), health) == []
    assert health.counters["rejected.no_date"] == 40
    assert health.counters["errors"] == 1 and "--date" in health.last_error


def test_held_lines_are_bounded(make_health, monkeypatch):
    monkeypatch.setattr(ikonvert, "HOLD", 20)
    log = b"".join(_heading(1000 * i) for i in range(25)) + _system_time(25_000, 19000, 25.0)
    health = make_health("ik")
    ms = _decode(log, health)
    assert health.counters["rejected.no_date"] == 5
    assert [m.t for m in ms] == pytest.approx([19000 * DAY + i for i in range(5, 25)], abs=1e-6)


def test_the_timer_runs_on_past_midnight(make_health):
    log = _system_time(100_000, 19000, 86399.5) + _heading(100_400) + _heading(100_600)
    ms = _decode(log, make_health("ik"))
    assert [m.t for m in ms] == pytest.approx([19000 * DAY + 86399.9, 19001 * DAY + 0.1], abs=1e-6)


def test_a_gateway_restart_is_counted_and_dated_again(make_health):
    # Timer 500 s, then the gateway restarts: 2 s. The lines after the restart wait
    # for the next 126992 and are placed by it, not 498 s back in time.
    log = _system_time(500_000, 19000, 1000.0) + _heading(500_100)
    log += _heading(2_000) + _system_time(3_000, 19000, 1010.0) + _heading(3_500)
    health = make_health("ik")
    ms = _decode(log, health)
    d = 19000 * DAY
    assert health.counters["timer_restarts"] == 1
    assert [m.t for m in ms] == pytest.approx([d + 1000.1, d + 1009.0, d + 1010.5], abs=1e-6)
    assert not [k for k in health.counters if k.startswith("rejected.")]


def test_a_restart_without_a_time_after_it_goes_on_from_the_last_time(make_health):
    log = _system_time(500_000, 19000, 1000.0) + _heading(500_100) + _heading(2_000) + _heading(2_500)
    health = make_health("ik")
    ms = _decode(log, health)
    d = 19000 * DAY
    assert health.counters["timer_restarts"] == 1
    assert [m.t for m in ms] == pytest.approx([d + 1000.1, d + 1002.1, d + 1002.6], abs=1e-6)


def test_status_lines_are_counted_not_measurements_and_a_glued_one_is_split(make_health):
    log = _system_time(1_000, 19000, 10.0)
    log += b"$PDGY,000000,4,,5,482,1,0\n"
    log += _heading(1_500).rstrip() + b"$PDGY,000000,3,,5,483,1,0\n"  # cut in, no line end
    health = make_health("ik")
    ms = _decode(log, health)
    assert health.counters["gateway_status"] == 2
    assert [m.kind for m in ms] == ["heading"]
    with pytest.raises(Bad) as status:  # a live status line: counted by the decoder, not decoded
        ikonvert.frame(b"$PDGY,000000,4,,5,482,1,0")
    assert status.value.reason == "gateway_status"
    # a live stream's line, not split by `read`: the message, the status left out
    glued = _heading(1_500).rstrip() + b"$PDGY,000000,3,,5,483,1,0"
    assert [(x.pgn, x.src, len(x.payload)) for x in ikonvert.frame(glued)] == [(127250, 7, 8)]


# ---- round trip: candump and iKonvert of the same PGN stream -------------------------


def _messages(build, n: int = 3000):
    """(t, prio, pgn, src, dst, payload): a 126992 first, heading, rate of turn, and
    129029 (a fast-packet PGN: frames in candump, one whole message in iKonvert)."""
    t0 = 1_700_000_000
    days, secs = divmod(t0, DAY)
    out = [(float(t0), 3, 126992, 3, 255, struct.pack("<BBHI", 0, 0xF0, days, secs * 10_000))]
    for i in range(n // 3):
        t = (t0 * 1000 + 100 * i + 1) / 1000.0
        out.append((t, 2, 127250, 7, 255, struct.pack("<BHhhB", i & 0xFF, (i * 37) % 62831, 0x7FFF, 0x7FFF, 0xFC)))
        out.append((t + 0.01, 2, 127251, 7, 255, struct.pack("<BiBBB", i & 0xFF, 1000 * (i % 50 - 25), 0xFF, 0xFF, 0xFF)))
        if i % 10 == 0:
            out.append((t + 0.02, 3, 129029, 160, 255, build.pgn_129029(54.0 + i * 1e-5, 7.0, days=days, secs=secs + 0.1 * i)))
    return out


def test_round_trip_candump_and_ikonvert_give_identical_measurements(make_health, build):
    msgs = _messages(build)
    t0 = msgs[0][0]
    dump = []
    for t, p, pgn, s, d, payload in msgs:
        frames = build.fast_frames(payload, seq=0) if len(payload) > 8 else [payload]
        dump += [f"({t + 0.001 * k:.6f}) bus {can_id(p, pgn, s, d):08X}#{fr.hex().upper()}\n".encode()
                 for k, fr in enumerate(frames)]
    # iKonvert stamps the reassembled message when its last frame arrived: timer
    # 100 s at t0
    ik = b""
    for t, p, pgn, s, d, payload in msgs:
        last = 0.001 * (len(build.fast_frames(payload)) - 1) if len(payload) > 8 else 0.0
        ik += _pdgy(pgn, 100_000 + round((t + last - t0) * 1000), payload, src=s, prio=p, dst=d)
    dump_b = b"".join(dump)
    assert ikonvert.sniff(ik) and not candump.sniff(ik) and not actisense_plain.sniff(ik) and not ydwg_raw.sniff(ik)
    health = make_health("a")
    decoder = CanInput.make_decoder("bus", None, health)
    a = [m for raw in CANDUMP.open(io.BytesIO(dump_b), "bus", health, ReplayOptions()) for m in decoder.decode(raw)]
    b = _decode(ik, make_health("b"), source="bus")
    assert len(a) == 2 * 1000 + 100
    assert [(m.kind, m.source, round(m.t, 3), m.values, m.t_src) for m in a] == [
        (m.kind, m.source, round(m.t, 3), m.values, m.t_src) for m in b
    ]


# ---- bad lines -----------------------------------------------------------------------

GOOD = _pdgy(127250, 100_000, struct.pack("<BHhhB", 0, 10000, 0x7FFF, 0x7FFF, 0xFC))  # heading 1.0 rad, true
GOOD2 = _pdgy(127250, 101_000, struct.pack("<BHhhB", 0, 10000, 0x7FFF, 0x7FFF, 0xFC))
BAD = [
    (b"!PDGY,127250,2,7,255,100.500\n", "rejected.bad_line"),  # no payload field
    (b"xx!PDGY,127250,2,7,255,100.500,ABAn/3//f/w=\n", "rejected.bad_line"),  # junk in front
    (b"!PDGY,127250,9,7,255,100.500,ABAn/3//f/w=\n", "rejected.bad_line"),  # priority 9
    (b"!PDGY,127250,2,7,255,100.500,\n", "rejected.bad_length"),  # empty payload
    (b"!PDGY,127250,2,7,255,100.500," + base64.b64encode(bytes(224)) + b"\n", "rejected.bad_length"),
    (b"!PDGY,127250,2,7,255,100.500,AB*n/3//f/w=\n", "rejected.bad_base64"),
    (b"!PDGY,127250,2,7,255,100.500,AB\n", "rejected.bad_base64"),  # cut short: bad padding
    (b"!PDGY,999999,2,7,255,100.500,AAAAAAAAAAA=\n", "rejected.bad_pgn"),  # beyond 18 bits
    (b"!PDGY,127250,2,300,255,100.500,AAAAAAAAAAA=\n", "rejected.bad_address"),
]


@pytest.mark.parametrize("line,counter", BAD)
def test_bad_lines_are_counted_and_the_rest_go_on(make_health, line, counter):
    health = make_health("bad")
    ms = _decode(GOOD + line + GOOD2, health, date="2024-01-01")
    assert health.counters[counter] == 1
    assert [m.kind for m in ms] == ["heading", "heading"]
    assert all(math.isfinite(m.values["heading"]) and m.values["heading"] == pytest.approx(1.0) for m in ms)
    assert [m.t for m in ms] == pytest.approx([19723 * DAY + 100.0, 19723 * DAY + 101.0], abs=1e-6)


def test_a_timer_going_back_a_little_is_jitter_not_a_restart(make_health):
    health = make_health("ik")
    ms = _decode(_heading(100_000) + _heading(99_500) + _heading(100_100), health, date="2024-01-01")
    assert len(ms) == 3 and health.counters.get("timer_restarts", 0) == 0


# ---- sniffing ------------------------------------------------------------------------


def test_sniff_claims_only_ikonvert_logs(n2k_data):
    for path in sorted(Path(n2k_data).iterdir()):
        head = path.read_bytes()[:4096]
        assert ikonvert.sniff(head) == (path.name == REAL), path.name
    head = (n2k_data / REAL).read_bytes()[:4096]
    assert not candump.sniff(head) and not actisense_plain.sniff(head) and not ydwg_raw.sniff(head)
    gga = b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n"
    ais = b"!AIVDM,1,1,,B,177KQJ5000G?tO`K>RA1wUbN0TKH,0*5C\r\n"
    for other in (gga, gga * 10, ais * 10, b"$PDGY,000000,4,,5,482,1,0\r\n" * 5):
        assert not ikonvert.sniff(other)
