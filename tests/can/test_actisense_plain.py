"""canboat / Actisense "plain" logs: the five real ones, round trip with candump, bad lines.

Expected per-PGN message counts are those of ../shared/data/INDEX.md ("Key PGNs
(messages)"), which were counted independently of edged (fast-packet PGNs by first
frame). Decoded values were read by hand from the first line of the PGN in each file,
with the NMEA 2000 layouts (heading: bytes 1-2 little-endian × 1e-4 rad).
"""

from __future__ import annotations

import io
import math

import pytest

from edged.plugin import ReplayOptions
from edged_can import candump
from edged_can.formats import actisense_plain, can_id
from edged_can.logs import ACTISENSE_PLAIN, CANDUMP
from edged_can.plugin import CanInput

FILES = {
    "canboat__samples__dirona-actisense-serial.raw": {
        127250: 6440, 127251: 6440, 127257: 5284, 127258: 450, 128259: 130, 128267: 130,
        129025: 1934, 129026: 1934, 129029: 258, 126992: 256,
    },
    "canboat__samples__furuno-fap7011c-autopilot-maneuvers.raw": {
        127250: 6848, 127251: 1712, 127257: 172, 127258: 172, 128259: 855, 128267: 171,
        129025: 856, 129026: 856, 129029: 295, 126992: 172,
    },
    "canboat__samples__susteranna-actisense-serial.raw": {
        127250: 941, 127251: 1255, 127257: 659, 127258: 161, 128259: 562, 128267: 31,
        129025: 936, 129026: 564, 129029: 93, 126992: 93,
    },
    # PLAIN_MIX_FAST: fast-packet PGNs both reassembled and as frames; counted once.
    "canboat__samples__susteranna2020.raw": {
        127250: 396, 127251: 536, 127257: 415, 127258: 61, 128259: 129, 128267: 39,
        129025: 244, 129026: 172, 129029: 27, 126992: 25,
    },
    # Signal K's .data: fast-packet PGNs reassembled (129029 has len 43).
    "signalk-server__samples__aava-n2k.data": {
        127250: 596, 128259: 1798, 128267: 599, 129025: 597, 129026: 596, 129029: 597, 126992: 597,
    },
}


def _decode(stream, source, health, reader=ACTISENSE_PLAIN):
    decoder = CanInput.make_decoder(source, None, health)
    out = []
    for raw in reader.open(stream, source, health, ReplayOptions()):
        out.extend(decoder.decode(raw))
    return out


@pytest.mark.parametrize("name", sorted(FILES))
def test_real_plain_logs_give_the_index_counts(n2k_data, make_health, name):
    path = n2k_data / name
    with path.open("rb") as f:
        assert ACTISENSE_PLAIN.sniff(f.read(4096))
        f.seek(0)
        health = make_health(path.stem)
        ms = _decode(io.BufferedReader(f), path.stem, health)
    c = health.counters
    for pgn, n in FILES[name].items():
        assert c.get(f"pgn.{pgn}", 0) == n, (pgn, c.get(f"pgn.{pgn}"))
    assert c.get("rejected.bad_line", 0) == 0 and c.get("rejected.bad_length", 0) == 0
    assert c.get("fastpacket.lost", 0) == 0
    assert ms and all(m.t > 1.3e9 for m in ms)  # the log's own dates, never 1970


def test_values_read_by_hand(n2k_data, make_health):
    # dirona, first line: 2016-02-28T19:57:02.364Z,2,127250,7,255,8,ff,10,3b,ff,7f,ce,f5,fc
    # heading 0x3b10 = 15120 → 1.5120 rad; reference (byte 7 & 3) = 0: true.
    with (n2k_data / "canboat__samples__dirona-actisense-serial.raw").open("rb") as f:
        head = b"".join(f.readline() for _ in range(400))
    health = make_health("dirona")
    ms = _decode(io.BytesIO(head), "dirona", health)
    hdg = [m for m in ms if m.kind == "heading" and m.source == "dirona.7"]
    assert hdg[0].values["heading"] == pytest.approx(1.5120, abs=1e-9)
    assert hdg[0].t == pytest.approx(1456689422.364)


def _frames(n: int = 3000):
    """(t, prio, pgn, src, dst, data) of a synthetic bus: heading and rate of turn, as a
    sender would put them on the bus."""
    import struct

    out = []
    for i in range(n // 3):
        t = (1_700_000_000_000 + 100 * i) / 1000.0  # whole milliseconds
        hd = struct.pack("<BHhhB", i & 0xFF, (i * 37) % 62831, 0x7FFF, 0x7FFF, 0xFC)
        out.append((t, 2, 127250, 7, 255, hd))
        out.append((t + 0.01, 2, 127251, 7, 255, struct.pack("<BiBBB", i & 0xFF, 1000 * (i % 50 - 25), 0xFF, 0xFF, 0xFF)))
    return out


def test_round_trip_candump_and_plain_give_identical_measurements(make_health):
    frames = _frames()
    dump = b"".join(
        f"({t:.6f}) bus {can_id(p, pgn, s, d):08X}#{data.hex().upper()}\n".encode() for t, p, pgn, s, d, data in frames
    )
    plain = b"".join(
        (f"{_iso(t)},{p},{pgn},{s},{d},{len(data)}," + ",".join(f"{b:02x}" for b in data) + "\n").encode()
        for t, p, pgn, s, d, data in frames
    )
    assert candump.sniff(dump) and actisense_plain.sniff(plain) and not candump.sniff(plain)
    a = _decode(io.BytesIO(dump), "bus", make_health("a"), CANDUMP)
    b = _decode(io.BytesIO(plain), "bus", make_health("b"))
    assert len(a) == len(frames) and [(m.kind, m.source, round(m.t, 3), m.values) for m in a] == [
        (m.kind, m.source, round(m.t, 3), m.values) for m in b
    ]


def _iso(t: float) -> str:
    """ISO 8601 to the millisecond, as the plain format writes it (t has whole ms)."""
    from datetime import datetime, timezone

    ms = round(t * 1000)
    return datetime.fromtimestamp(ms // 1000, timezone.utc).strftime("%Y-%m-%dT%H:%M:%S") + f".{ms % 1000:03d}Z"


def test_reassembled_and_framed_copies_of_one_message_decode_once(make_health):
    # 129029 (GNSS position, fast-packet): its 43-byte payload as frames, then whole.
    import struct

    days, secs = 19000, 43200.0
    payload = struct.pack("<BHIqqq", 1, days, int(secs * 1e4), int(54.0 * 1e16), int(7.0 * 1e16), 10 * 10**6)
    payload += bytes([0x10, 0xFC, 12]) + struct.pack("<hhi", 90, 150, 4000) + b"\x00"
    assert len(payload) == 43
    frames = [bytes([0, 43]) + payload[:6]] + [bytes([i]) + payload[6 + 7 * (i - 1):6 + 7 * i] for i in range(1, 7)]
    frames = [f.ljust(8, b"\xff") for f in frames]
    t0 = "2024-01-01T12:00:00.0"
    lines = [f"{t0}{i:02d}Z,3,129029,160,255,8," + ",".join(f"{b:02x}" for b in fr) for i, fr in enumerate(frames)]
    lines.append(f"{t0}10Z,3,129029,160,255,43," + ",".join(f"{b:02x}" for b in payload))
    lines.append(f"{t0}20Z,3,129029,160,255,43," + ",".join(f"{b:02x}" for b in payload))  # a second, whole only
    lines += [f"{t0}30Z,3,129029,160,255,8," + ",".join(f"{b:02x}" for b in fr) for fr in frames]  # frames again
    health = make_health("mix")
    ms = _decode(io.BytesIO(("\n".join(lines) + "\n").encode()), "mix", health)
    pos = [m for m in ms if m.kind == "position"]
    assert len(pos) == 2  # the framed copy, then the second whole message
    assert health.counters["duplicates.fast_messages"] == 1
    assert health.counters["duplicates.fast_frames"] == len(frames)
    assert pos[0].values["lat"] == pytest.approx(54.0) and pos[0].values["lon"] == pytest.approx(7.0)


BAD = [
    (b"2024-01-01T12:00:00.000Z,2,127250,7,255,8,ff,10,3b\n", "rejected.bad_length"),  # says 8, has 3
    (b"2024-01-01T12:00:00.000Z,2,127250,700,255,8,ff,10,3b,ff,7f,ce,f5,fc\n", "rejected.bad_address"),
    (b"2024-01-01T12:00:00.000Z,0,16712965,255,0,0\n", "gateway_messages"),  # Actisense's own
    (b"2024-01-01T12:00:00.000Z,2,127250,7,255,8,zz,10,3b,ff,7f,ce,f5,fc\n", "rejected.bad_line"),
    (b"2024-02-30T12:00:00.000Z,2,127250,7,255,8,ff,10,3b,ff,7f,ce,f5,fc\n", "rejected.bad_time"),  # no such day
    (b"1970-01-01T00:00:01.000Z,2,127250,7,255,8,ff,10,3b,ff,7f,ce,f5,fc\n", "rejected.bad_time"),
]
GOOD = b"2024-01-01T12:00:00.000Z,2,127250,7,255,8,ff,10,3b,ff,7f,ce,f5,fc\n"


@pytest.mark.parametrize("line,counter", BAD)
def test_bad_lines_are_counted_and_the_rest_go_on(make_health, line, counter):
    health = make_health("bad")
    ms = _decode(io.BytesIO(GOOD + line + GOOD), "bad", health)
    assert health.counters[counter] == 1
    assert [m.kind for m in ms] == ["heading", "heading"]
    assert all(math.isfinite(m.values["heading"]) for m in ms)


def test_a_recording_keeps_the_gateway_lines_and_replays_through_the_same_decoder(n2k_data, tmp_path):
    """Raw records hold the gateway's own line (meta format = actisense_plain): the
    MCAP made from a plain log gives the very same measurements when replayed."""
    import contextlib
    import re

    from edged.cli import main as cli

    def replay(*args: str) -> dict[str, int]:
        out = io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
            assert cli(["replay", *args, "--no-zenoh", "--no-progress"]) == 0
        return {k: int(v) for k, v in re.findall(r"(measurements\.\w+)\s+(\d+)", out.getvalue())}

    log = n2k_data / "canboat__samples__susteranna2020.raw"
    rec = tmp_path / "plain.mcap"
    first = replay(str(log), "--record", str(rec))
    again = replay(str(rec))
    assert first and first == again
    from mcap.reader import make_reader

    with rec.open("rb") as f:
        raw = next(m for _, ch, m in make_reader(f).iter_messages() if ch.topic.startswith("/raw/can/"))
    import json

    msg = json.loads(raw.data)
    assert msg["meta"] == {"format": "actisense_plain"}
    assert bytes.fromhex(msg["data"]).startswith(b"2020-08-22T13:52:36.949Z,2,65280,29,255,8,")


def test_a_whole_message_makes_only_nearby_frames_duplicates(make_health):
    """One reassembled 129029 does not silence the same PGN's frames an hour later."""
    import struct

    payload = struct.pack("<BHIqqq", 1, 19000, 432000000, int(54.0 * 1e16), int(7.0 * 1e16), 10 * 10**6)
    payload += bytes([0x10, 0xFC, 12]) + struct.pack("<hhi", 90, 150, 4000) + b"\x00"
    frames = [bytes([0, 43]) + payload[:6]] + [bytes([i]) + payload[6 + 7 * (i - 1):6 + 7 * i] for i in range(1, 7)]
    hexes = lambda b: ",".join(f"{x:02x}" for x in b)  # noqa: E731
    lines = [f"2024-01-01T12:00:00.000Z,3,129029,160,255,43,{hexes(payload)}"]
    padded = [fr.ljust(8, b"\xff") for fr in frames]
    lines += [f"2024-01-01T13:00:00.{i:03d}Z,3,129029,160,255,8,{hexes(fr)}" for i, fr in enumerate(padded)]
    health = make_health("mix")
    ms = _decode(io.BytesIO(("\n".join(lines) + "\n").encode()), "mix", health)
    assert [m.kind for m in ms] == ["position", "position"]
    assert health.counters.get("duplicates.fast_frames", 0) == 0


def test_an_impossible_time_of_day_is_a_bad_time(make_health):
    health = make_health("bad")
    ms = _decode(io.BytesIO(GOOD + GOOD.replace(b"T12:00", b"T24:30") + GOOD), "bad", health)
    assert health.counters["rejected.bad_time"] == 1 and len(ms) == 2
