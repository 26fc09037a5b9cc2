"""CAN input throughput for the reference sensor mix, against NMEA 2000 bus saturation.

Per second of log: 600 draft frames (6 marks at 100 Hz), 150 IMU frames (accel, rate,
attitude at 50 Hz) and 50 NMEA 2000 navigation frames (heading, rate of turn, position
rapid, COG/SOG at 10 Hz; GNSS position data as a 7-frame fast-packet, STW, depth and
variation at 1 Hz). A 250 kbit/s NMEA 2000 bus saturates near 1,700 frames/s; the
target is 20x that on one core.

    .venv/bin/python tests/bench/bench_can.py [seconds-of-log]
"""

from __future__ import annotations

import io
import math
import random
import struct
import sys
import time

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import RawRecord
from edged_can.logs import CANDUMP
from edged_can.plugin import CanInput

SATURATION = 1700.0
T0 = 1732350000.0


def n2k_id(pgn: int, src: int, prio: int = 2) -> int:
    return (prio << 26) | (pgn << 8) | src


def fast_frames(payload: bytes, seq: int) -> list[bytes]:
    frames = [bytes([seq << 5, len(payload)]) + payload[:6]]
    rest, i = payload[6:], 1
    while rest:
        frames.append(bytes([(seq << 5) | i]) + rest[:7])
        rest, i = rest[7:], i + 1
    return [f.ljust(8, b"\xff") for f in frames]


def one_second(sec: int, rng: random.Random) -> list[tuple[float, int, bool, bytes]]:
    t = T0 + sec
    out: list[tuple[float, int, bool, bytes]] = []
    for k in range(100):
        for mark in range(6):
            draft = round((8.0 + 0.3 * math.sin(0.5 * (t + k / 100)) + rng.gauss(0, 0.01)) / 0.001)
            out.append((t + k / 100 + mark * 1e-4, 0x310 + mark, False, struct.pack("<HBB", draft, 0, (sec * 100 + k) & 0xFF)))
    for k in range(50):
        tk = t + k / 50 + 5e-3
        out.append((tk, 0x320, False, struct.pack("<hhh", rng.randint(-500, 500), rng.randint(-500, 500), rng.randint(-200, 200))))
        out.append((tk + 1e-4, 0x321, False, struct.pack("<ihh", rng.randint(-50_000, 50_000), 0, 0)))
        out.append((tk + 2e-4, 0x322, False, struct.pack("<hhh", rng.randint(-800, 800), rng.randint(-300, 300), rng.randint(-500, 500))))
    for k in range(10):
        tk = t + k / 10 + 7e-3
        out.append((tk, n2k_id(127250, 28), True, struct.pack("<BHhhB", k, rng.randint(0, 62831), 0x7FFF, 0x7FFF, 0xFC)))
        out.append((tk + 1e-4, n2k_id(127251, 28), True, struct.pack("<Bi", k, rng.randint(-2_000_000, 2_000_000)) + b"\xff" * 3))
        out.append((tk + 2e-4, n2k_id(129025, 20), True, struct.pack("<ii", 601_234_567 + k, 245_678_901 + k)))
        out.append((tk + 3e-4, n2k_id(129026, 20), True, struct.pack("<BBHHH", k, 0xFC, rng.randint(0, 62831), 515, 0xFFFF)))
    gnss = struct.pack("<BHIqqqBBBhhiB", 1, 20000, 36_000_000, 601_234_567 * 10**9, 245_678_901 * 10**9, 0, 0x10, 0xFC, 10, 80, 120, 0, 0)
    for i, f in enumerate(fast_frames(gnss, sec & 7)):
        out.append((t + 0.5 + i * 1e-4, n2k_id(129029, 20, 3), True, f))
    out.append((t + 0.6, n2k_id(128259, 35), True, struct.pack("<BHHBB", 0, 612, 0xFFFF, 0, 0xFF) + b"\xff"))
    out.append((t + 0.6001, n2k_id(128267, 35), True, struct.pack("<BIhB", 0, 1234, 500, 0xFF)))
    out.append((t + 0.6002, n2k_id(127258, 20), True, struct.pack("<BBHhH", 0, 0xF1, 0xFFFF, 1000, 0xFFFF)))
    out.sort()
    return out


def main() -> None:
    seconds = int(sys.argv[1]) if len(sys.argv) > 1 else 60
    rng = random.Random(1)
    frames = [f for s in range(seconds) for f in one_second(s, rng)]
    per_second = len(frames) / seconds
    raws = [RawRecord("can", "can0", t, d, {"id": i, "ext": e}) for t, i, e, d in frames]
    text = "".join(f"({t:.6f}) can0 {i:08X}#{d.hex().upper()}\n" if e else f"({t:.6f}) can0 {i:03X}#{d.hex().upper()}\n"
                   for t, i, e, d in frames).encode()

    health = ComponentHealth("can0", "input", "can", ManualClock())
    dec = CanInput.make_decoder("can0", None, health)
    t0 = time.perf_counter()
    n_meas = sum(len(dec.decode(r)) for r in raws)
    dt_decode = time.perf_counter() - t0

    health2 = ComponentHealth("can0", "input", "can", ManualClock())
    dec2 = CanInput.make_decoder("can0", None, health2)
    t0 = time.perf_counter()
    n2 = 0
    for raw in CANDUMP.open(io.BytesIO(text), "bench", health2, ReplayOptions()):
        n2 += len(dec2.decode(raw))
    dt_replay = time.perf_counter() - t0

    fps = len(raws) / dt_decode
    fps_replay = len(raws) / dt_replay
    c = health.counters
    print(f"mix: {per_second:.0f} frames per second of log, {seconds} s = {len(raws)} frames "
          f"({c['frames.dbc']} DBC, {c['frames.n2k']} N2K), {n_meas} measurements")
    print(f"decode only          : {fps:9.0f} frames/s = {fps / SATURATION:5.1f}x N2K saturation "
          f"(~{SATURATION:.0f} frames/s), real-time factor {fps / per_second:6.1f}")
    print(f"candump parse+decode : {fps_replay:9.0f} frames/s = {fps_replay / SATURATION:5.1f}x saturation, "
          f"real-time factor {fps_replay / per_second:6.1f}")
    rejected = {k: v for k, v in c.items() if k.startswith(("rejected", "fastpacket"))}
    print(f"rejections/fast-packet problems: {rejected or 'none'}")
    print("target >= 20x saturation:", "met" if fps / SATURATION >= 20 else "NOT met")


if __name__ == "__main__":
    main()
