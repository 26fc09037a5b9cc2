"""candump logs: recognised in every layout can-utils writes, nothing else claimed."""

from __future__ import annotations

import io
import re
from pathlib import Path

import pytest

from edged.plugin import ReplayOptions
from edged_can.logs import CANDUMP
from edged_can.plugin import CanInput

LOG_L = b"(1732350000.123456) can0 09F11201#0011223344556677\n(1732350000.223456) can0 320#E803\n"
SCREEN_T = b"(1502984866.421964)  slcan0  09F112CC   [8]  FF 72 5A FF 7F FF 7F FD\n"
SCREEN = b"  can0  09F8027F   [8]  00 FC FF FF 00 00 FF FF\n  can0  321   [2]  01 02\n"
OLD = b"# header\ninterface = can0, family = 29, type = 3, proto = 1\n<0x18eeff01> [8] 05 a0 be 1c 00 a0 a0 c0 \n"
NOT_CANDUMP = [
    b"2016-02-28T19:57:02.364Z,2,127250,7,255,8,ff,7f,fb,ff,7f,ff,7f,fd\n",  # Actisense plain
    b"19:57:02.364 R 09F10D0B 00 FF FF 7F FF 7F FD FF\n",  # YDWG raw
    b"!PDGY,127250,2,3,255,482.37,AP//f/9//3/9\n",  # iKonvert
    b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\n",  # NMEA 0183
    b"\x89MCAP0\r\n",
    b"",
]


def _read(text: bytes, health, config=None, source="file") -> list:
    return list(CANDUMP.open(io.BytesIO(text), source, health, ReplayOptions(config=config)))


@pytest.mark.parametrize("head", [LOG_L, SCREEN_T, SCREEN, OLD])
def test_sniff_recognises_candump_layouts(head):
    assert CANDUMP.sniff(head)


@pytest.mark.parametrize("head", NOT_CANDUMP)
def test_sniff_rejects_other_formats(head):
    from edged_can import candump

    assert not candump.sniff(head)


def test_sniff_ignores_a_line_cut_by_the_head():
    assert CANDUMP.sniff(LOG_L + b"(1732350000.3) can0 09F1")


def test_log_format(health):
    a, b = _read(LOG_L, health)
    assert (a.protocol, a.source, a.t, a.data, a.meta) == (
        "can", "can0", 1732350000.123456, bytes.fromhex("0011223344556677"), {"id": 0x09F11201, "ext": True}
    )
    assert (b.data, b.meta) == (bytes.fromhex("E803"), {"id": 0x320, "ext": False})


def test_screen_formats_with_and_without_time(health):
    (a,) = _read(SCREEN_T, health)
    assert (a.source, a.t, a.meta["id"], a.data[:2]) == ("slcan0", 1502984866.421964, 0x09F112CC, b"\xff\x72")
    x, y = _read(SCREEN, health)
    assert (x.t, x.meta, y.meta, y.data) == (0.0, {"id": 0x09F8027F, "ext": True}, {"id": 0x321, "ext": False}, b"\x01\x02")
    assert health.counters["untimed"] == 2
    assert "without timestamps" in health.last_error


def test_old_format_takes_the_file_source(health):
    (a,) = _read(OLD, health, source="sample1")
    assert (a.source, a.meta, a.data[0]) == ("sample1", {"id": 0x18EEFF01, "ext": True}, 0x05)


def test_a_configured_input_names_the_bus(health):
    (a, _) = _read(LOG_L, health, config=object(), source="engine_bus")
    assert a.source == "engine_bus"


def test_bad_lines_remote_and_error_frames_are_counted_and_skipped(health):
    text = (
        b"(1.0) can0 123#R\n"
        b"(2.0) can0 20000004#0004000000000000\n"
        b"(3.0) can0 12G#00\n"
        b"(4.0) can0 123#0\n"
        b"  can0  123   [4]  00 01\n"
        b"(x) can0 123#00\n"
        b"garbage\n"
        b"(5.0) can0 800#00\n"
        b"(6.0) can0 123##1AABB\n"
    )
    recs = _read(text, health)
    assert [(r.t, r.data) for r in recs] == [(6.0, b"\xaa\xbb")]  # CAN FD data kept
    c = health.counters
    assert (c["remote_frames"], c["error_frames"], c["rejected.bad_line"]) == (1, 1, 6)
    assert re.match(r"line \d+: not a candump frame", health.last_error)


# ---- the real logs in shared/data ------------------------------------------------

# Messages per key PGN in shared/data/INDEX.md (fast-packets counted once).
INDEX_COUNTS = {
    "canboat__samples__can0-1.pcap__DERIVED_candump-l.log": {
        127250: 1788, 127251: 2382, 127257: 1889, 127258: 384, 128259: 410, 128267: 416,
        129025: 1632, 129026: 1393, 129029: 351, 126992: 177,
    },
    "canboat__samples__candumpSample1.txt": {
        128259: 99, 128267: 99, 129025: 963, 129026: 385, 129029: 97, 126992: 97,
    },
}


def _candump_logs(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if "candump" in p.name)


def test_every_shared_candump_log_replays(n2k_data, make_health):
    logs = _candump_logs(n2k_data)
    assert len(logs) == 4
    for path in logs:
        health = make_health(path.stem)
        with path.open("rb") as f:
            assert CANDUMP.sniff(f.read(4096)), path.name
            f.seek(0)
            decoders: dict = {}
            n = 0
            for raw in CANDUMP.open(f, path.stem, health, ReplayOptions(path=path)):
                if raw.source not in decoders:
                    decoders[raw.source] = CanInput.make_decoder(raw.source, None, health)
                decoders[raw.source].decode(raw)
                n += 1
        c = health.counters
        assert n > 0 and c["frames"] == n and c.get("rejected.bad_line", 0) == 0, path.name
        for pgn, expected in INDEX_COUNTS.get(path.name, {}).items():
            assert c[f"pgn.{pgn}"] == expected, (path.name, pgn)
        assert c.get("fastpacket.lost", 0) == 0


def test_other_n2k_formats_are_not_claimed_by_candump(n2k_data):
    from edged_can import candump

    others = [p for p in n2k_data.iterdir() if "candump" not in p.name]
    assert others
    for path in others:
        with path.open("rb") as f:
            assert not candump.sniff(f.read(4096)), path.name
