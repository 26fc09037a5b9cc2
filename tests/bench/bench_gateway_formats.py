"""NMEA 2000 gateway log formats: records per second through read + decode, on one core.

Each real log of ../shared/data/n2k is read from memory by its format's reader and
every record decoded by the CAN decoder (`CanInput.make_decoder(...).decode`), as
`edged replay` does, repeated until at least `--seconds` of CPU time (the best
repetition counts). Yacht Devices RAW, Actisense plain and candump records are CAN
frames; an iKonvert record is a whole message (a fast-packet PGN is several bus
frames in one). The target is 20x NMEA 2000 bus saturation (1,700 frames/s) on one
core.

No real `$PCDIN` / `$MXPGN` log is at hand: those two are made in memory from the
frames of the candump -l log (`_made_pcdin`, `_made_mxpgn`), each line with the NMEA
4.10 TAG block time (`\\c:<UNIX ms>*hh\\`) a logger adds, and read as `edged replay`
reads an NMEA 0183 file (`edged_nmea0183.logfile.read_log`, the records then through
the CAN decoder). `$MXPGN`: one sentence a frame, as a MiniPlex sends them (our
builder: the `nmea2000` package's MxpgnEncoder writes a fast-packet PGN whole in one
sentence, which no MiniPlex does). `$PCDIN`: one sentence a message, the fast-packets
reassembled by the package's canboat reassembler (all PGNs kept, which decoding and
re-encoding them by field would not), the log twice (the second pass one span later)
for about 50 k lines; a record is a message, as for iKonvert. The live-only Actisense
formats are made from the same messages: BST 93 (an NGT-1) and BST 95 (an NGX in raw
CAN mode) as a byte stream cut by the live input's deframer in 4 KiB reads, N2K ASCII
one line a message. The decoders' warnings (once per reason per repetition) are off.

    .venv/bin/python tests/bench/bench_gateway_formats.py [--seconds S]
"""

from __future__ import annotations

import argparse
import io
import logging
import sys
import time
from pathlib import Path

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged_can import candump
from edged.records import RawRecord
from edged_can.formats import actisense_plain, ikonvert, ydwg_raw
from edged_can.formats.actisense_bst import Deframer
from edged_can.plugin import CanInput
from edged_nmea0183 import logfile

SATURATION = 1700.0
DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "n2k"


def _ydwg(stream, health):
    return ydwg_raw.read(stream, "bench", health, ReplayOptions())


def _ikonvert(stream, health):
    return ikonvert.read(stream, "bench", health, ReplayOptions())


def _plain(stream, health):
    return actisense_plain.read(stream, "bench", health, ReplayOptions())


def _candump(stream, health):
    return candump.read(stream, "bench", health, bus_from_line=True)


def _nmea0183(stream, health):
    return logfile.read_log(stream, "bench", health, ReplayOptions())


def _sentence(body: str, t: float) -> str:
    """`\\c:<ms>*hh\\$<body>*hh`: a sentence with its TAG block time."""
    def cs(text: str) -> str:
        x = 0
        for ch in text:
            x ^= ord(ch)
        return f"{text}*{x:02X}"

    return "\\" + cs(f"c:{round(t * 1000)}") + "\\$" + cs(body) + "\n"


def _frames(path: Path) -> list[tuple[float, int, bytes]]:
    """(time, identifier, data) of every frame of a candump log, read by our reader."""
    health = ComponentHealth("bench", "input", "can", ManualClock(0.0))
    with path.open("rb") as f:
        return [(r.t, r.meta["id"], bytes(r.data)) for r in candump.read(f, "bench", health, bus_from_line=False)]


def _split(can_id: int) -> tuple[int, int, int]:
    """(priority, PGN, source) of a 29-bit identifier (PDU1: the destination is not the PGN)."""
    pgn = (can_id >> 8) & 0x3FFFF
    if (pgn >> 8) & 0xFF < 240:
        pgn &= 0x3FF00
    return (can_id >> 26) & 7, pgn, can_id & 0xFF


def _made_mxpgn(path: Path) -> bytes:
    out = []
    for t, can_id, data in _frames(path):
        prio, pgn, src = _split(can_id)
        attr = prio << 12 | len(data) << 8 | src
        out.append(_sentence(f"MXPGN,{pgn:06X},{attr:04X},{data[::-1].hex().upper()}", t))
    return "".join(out).encode()


_ISO_TP = (60160, 60416)  # transport-protocol frames: passed on as they are


def _made_pcdin(path: Path) -> bytes:
    from nmea2000._canboat import Reassembler

    frames = _frames(path)
    span = frames[-1][0] - frames[0][0] + 1.0
    out = []
    for shift in (0.0, span):
        join = Reassembler()
        for t, can_id, data in frames:
            prio, pgn, src = _split(can_id)
            payload = data if pgn in _ISO_TP else join.push(pgn, data, src, 255, prio)
            if payload:
                out.append(_sentence(f"PCDIN,{pgn:06X},00000000,{src:02X},{payload.hex().upper()}", t + shift))
    return "".join(out).encode()


def _messages(path: Path) -> list[tuple[float, int, int, int, bytes]]:
    """(time, priority, PGN, source, payload) of the candump log's messages, fast-packets
    reassembled by the package's canboat `Reassembler` (what an NGT-1 or NGX sends)."""
    from nmea2000._canboat import Reassembler

    join = Reassembler()
    out = []
    for t, can_id, data in _frames(path):
        prio, pgn, src = _split(can_id)
        payload = data if pgn in _ISO_TP else join.push(pgn, data, src, 255, prio)
        if payload:
            out.append((t, prio, pgn, src, payload))
    return out


def _stuff(msg: bytes) -> bytes:
    msg += bytes([(-sum(msg)) & 0xFF])
    return b"\x10\x02" + msg.replace(b"\x10", b"\x10\x10") + b"\x10\x03"


def _made_bst93(path: Path) -> bytes:
    """NGT-1 "N2K message received" (BST 93), one a message, twice over (~50 k)."""
    out = []
    for _ in range(2):
        for _t, prio, pgn, src, payload in _messages(path):
            body = bytes([prio]) + pgn.to_bytes(3, "little") + bytes([255, src]) + bytes(4) + bytes([len(payload)])
            out.append(_stuff(bytes([0x93, len(body) + len(payload)]) + body + payload))
    return b"".join(out)


def _made_bst95(path: Path) -> bytes:
    """BST 95 CAN frames (an NGX in raw mode), one a frame."""
    out = []
    for _t, can_id, data in _frames(path):
        prio, pgn, src = _split(can_id)
        ps = (can_id >> 8) & 0xFF
        out.append(_stuff(bytes([0x95, 6 + len(data), 0, 0, src, ps, (pgn >> 8) & 0xFF, prio << 2 | pgn >> 16]) + data))
    return b"".join(out)


def _made_ascii(path: Path) -> bytes:
    """Actisense N2K ASCII lines, one a message, twice over."""
    lines = []
    for _ in range(2):
        for _t, prio, pgn, src, payload in _messages(path):
            lines.append(f"A000000.000 {src << 12 | 0xFF0 | prio:05X} {pgn:05X} {payload.hex().upper()}\n")
    return "".join(lines).encode()


def _bst(stream, health):
    """The live input's path: 4 KiB reads through the deframer, a record a message."""
    deframer = Deframer(health)
    meta = {"format": "actisense_bst"}
    while chunk := stream.read(4096):
        for msg in deframer.feed(chunk):
            yield RawRecord("can", "bench", 0.0, msg, meta)


def _ascii(stream, health):
    meta = {"format": "actisense_ascii"}
    for line in stream:
        yield RawRecord("can", "bench", 0.0, line.strip(), meta)


def _file(path: Path) -> bytes:
    return path.read_bytes()


CANDUMP_LOG = "canboat__samples__can0-1.pcap__DERIVED_candump-l.log"
#: (format, real file, how its log is made from it, reader, what a record is)
CASES = [
    ("ydwg_raw", "canboat__samples__merrimac-ydwg-2020.raw", _file, _ydwg, "frames"),
    ("ikonvert", "canboat__samples__ikonvert.log", _file, _ikonvert, "messages"),
    ("actisense_plain", "canboat__samples__dirona-actisense-serial.raw", _file, _plain, "frames"),
    ("$PCDIN (made)", CANDUMP_LOG, _made_pcdin, _nmea0183, "messages"),
    ("$MXPGN (made)", CANDUMP_LOG, _made_mxpgn, _nmea0183, "frames"),
    ("BST 93 (made)", CANDUMP_LOG, _made_bst93, _bst, "messages"),
    ("BST 95 (made)", CANDUMP_LOG, _made_bst95, _bst, "frames"),
    ("N2K ASCII (made)", CANDUMP_LOG, _made_ascii, _ascii, "messages"),
    ("candump -l", CANDUMP_LOG, _file, _candump, "frames"),
]


def run_once(data: bytes, reader) -> tuple[int, int, float]:
    health = ComponentHealth("bench", "input", "can", ManualClock(0.0))
    decoder = CanInput.make_decoder("bench", None, health)
    decode = decoder.decode
    n = m = 0
    t0 = time.process_time()
    for raw in reader(io.BytesIO(data), health):
        n += 1
        m += len(decode(raw))
    return n, m, time.process_time() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="CPU time per format (default 2)")
    args = ap.parse_args()
    logging.getLogger("edged").setLevel(logging.CRITICAL)
    if not DATA.is_dir():
        print(f"{DATA} absent: nothing to measure")
        return 0
    print(f"{'format':<16} {'file':<52} {'records':>8} {'meas.':>7} {'per second':>20}  x saturation")
    for name, fname, make, reader, unit in CASES:
        path = DATA / fname
        if not path.is_file():
            print(f"{name:<16} {fname:<52} absent")
            continue
        data = make(path)
        best = float("inf")
        spent = 0.0
        reps = 0
        while spent < args.seconds or reps < 3:
            n, m, dt = run_once(data, reader)
            best = min(best, dt)
            spent += dt
            reps += 1
        rate = n / best
        print(f"{name:<16} {fname:<52} {n:>8} {m:>7} {rate:>9,.0f} {unit}/s  {rate / SATURATION:.0f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
