"""Benchmark: memory of `edged replay LOGS --record OUT.mcap` over a long voyage.

    .venv/bin/python tests/bench/bench_memory.py [--hours 24] [--scale 0.45]
                                                 [--no-record] [--keep DIR]

Writes a deterministic synthetic log of the reference sensor suite (DESIGN §9) to a
temporary folder: a candump log (six draft marks, IMU accelerations and rates, NMEA
2000 heading, rate of turn and attitude) and an NMEA 0183 log with TAG-block times
(HDT, ROT, GGA, VTG at 10 Hz, VBW at 1 Hz). At `--scale 1` that is the reference load,
about 740 messages per second of data; the default 0.45 thins the high-rate draft
marks and IMU (about 390 per second, half the MCAP bytes per hour), so that 24 hours of
data replay in about ten minutes on a 2-core machine. Memory per hour of recording
grows with the chunks written, i.e. with the bytes recorded: at a lower scale the same
growth shows, proportionally smaller per hour.

Then runs the real command line in a subprocess
(`python -m edged.cli replay can.log nmea.log --record OUT.mcap --no-zenoh`), samples
its resident memory (VmRSS and its high-water mark VmHWM in /proc/<pid>/status) every
0.2 s, and maps wall time to hours of data by how far the replay has read the candump
log (/proc/<pid>/fdinfo: the generator noted the byte offset of each hour). Prints the
peak RSS at 1, 6 and 24 hours of data (those of `--hours` that apply), the files the
recording was split into (`OUT.mcap`, `OUT.001.mcap`, ...; each checked readable with
its summary), and the messages recorded. `--no-record` runs the same replay without
recording, for the baseline.

Measured on the 2-core development machine (scale 0.45, 385 lines and about 780 MCAP
messages per second of data, 1.6 chunks per second): before the packed chunk index and
the rotation at 40,000 chunks, RSS grew 18 MB per hour of data (61 -> 79 -> 97 MB at
0, 1, 2 h); after, 61.6 MB when reading began, 65.6 MB at 1 h, 71.6 MB at 6 h, a peak of
80.1 MB at the rotation into OUT.001.mcap (7 h; the summary is built then) and 72.6 MB
at 8 h; without --record 62 MB throughout.
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from functools import reduce
from operator import xor
from pathlib import Path

from procstat import status  # noqa: E402  (this folder)

T0 = 1_732_350_000.0
MARKS = (1, 6, 24)


# -- the log ---------------------------------------------------------------------------
def _cs(body: str) -> str:
    return "%02X" % reduce(xor, body.encode(), 0)


def _nmea(t: float, body: str) -> str:
    tag = f"c:{t:.3f}"
    return f"\\{tag}*{_cs(tag)}\\${body}*{_cs(body)}\n"


def _can(t: float, ident: str, data: bytes) -> str:
    return f"({t:.6f}) can0 {ident}#{data.hex().upper()}\n"


def _i16(v: float) -> bytes:
    return int(max(-32768, min(32767, round(v)))).to_bytes(2, "little", signed=True)


def _u16(v: float) -> bytes:
    return int(max(0, min(65535, round(v)))).to_bytes(2, "little")


def _dm(deg: float, width: int) -> str:
    d = int(abs(deg))
    return f"{d:0{width}d}{(abs(deg) - d) * 60:07.4f}"


def write_logs(folder: Path, hours: float, scale: float) -> tuple[Path, Path, dict[float, int], int]:
    """The two logs, the candump log's byte offset at the end of each hour of data (and
    at the end), and the number of lines."""
    can_path, nmea_path = folder / "can.log", folder / "nmea.log"
    seconds = int(hours * 3600)
    draft_hz = max(1, round(100 * scale))
    imu_hz = max(1, round(50 * scale))
    offsets: dict[float, int] = {}
    can_bytes = 0
    n_lines = 0
    lat, lon = 60.0, 23.0
    with open(can_path, "w", buffering=1 << 20) as can, open(nmea_path, "w", buffering=1 << 20) as nmea:
        for s in range(seconds):
            t0 = T0 + s
            heading = (s * 0.01) % 360.0
            sog = 6.0 + math.sin(s / 600.0)
            cog = heading
            lat += sog * 0.514 / 111_000 * math.cos(math.radians(cog))
            lon += sog * 0.514 / 55_000 * math.sin(math.radians(cog))
            parts: list[str] = []
            for k in range(draft_hz):
                t = t0 + k / draft_hz
                for m in range(6):
                    mm = 14_000 + 150 * math.sin(t / 7.0 + m) + (k * 13 + m * 7) % 11
                    parts.append(_can(t, f"{0x310 + m:03X}", _u16(mm) + bytes([0, (s * draft_hz + k) & 0xFF])))
            for k in range(imu_hz):
                t = t0 + k / imu_hz + 0.008
                parts.append(_can(t, "320", _i16(31 + 10 * math.sin(t)) + _i16(32) + _i16(1)))
                parts.append(_can(t + 0.001, "321", _i16(82 + 5 * math.cos(t)) + _i16(0) + _i16(12) + _i16(-16)))
            for k in range(10):
                t = t0 + k / 10 + 0.001
                sid = (s * 10 + k) & 0xFF
                hd = round(math.radians(heading) * 10_000)
                parts.append(_can(t, "09F11212", bytes([sid]) + _u16(hd) + bytes.fromhex("FF7FFF7FFC")))
                parts.append(_can(t + 0.003, "09F11312", bytes([sid]) + bytes.fromhex("3BBCFFFFFFFFFF")))
                parts.append(_can(t + 0.010, "0DF1192D", bytes([sid]) + _i16(12) + _i16(-27) + _i16(59) + b"\xff"))
            chunk = "".join(parts)
            can.write(chunk)
            can_bytes += len(chunk)
            n_lines += len(parts)
            lines: list[str] = []
            for k in range(10):
                t = t0 + k / 10
                hh, mi, ss = time.gmtime(t)[3:6]
                utc = f"{hh:02d}{mi:02d}{ss:02d}.{k}0"
                lines.append(_nmea(t + 0.001, f"HEHDT,{heading:.2f},T"))
                lines.append(_nmea(t + 0.004, f"HEROT,{0.6 * math.sin(t / 60):.2f},A"))
                lines.append(_nmea(t + 0.006, f"GPGGA,{utc},{_dm(lat, 2)},N,{_dm(lon, 3)},E,1,10,0.8,3.0,M,18.0,M,,"))
                lines.append(_nmea(t + 0.007, f"GPVTG,{cog:.1f},T,,M,{sog:.2f},N,{sog * 1.852:.2f},K,A"))
            lines.append(_nmea(t0 + 0.014, f"VDVBW,{sog - 0.2:.2f},0.05,A,{sog:.2f},0.02,A"))
            nmea.write("".join(lines))
            n_lines += len(lines)
            if (s + 1) % 3600 == 0:
                offsets[(s + 1) / 3600] = can_bytes
    offsets[seconds / 3600] = can_bytes
    return can_path, nmea_path, offsets, n_lines


# -- the measurement -------------------------------------------------------------------
def _position(pid: int, target: Path) -> int | None:
    """Where the process's open file `target` is read up to (None: not open)."""
    try:
        for fd in os.listdir(f"/proc/{pid}/fd"):
            try:
                if os.readlink(f"/proc/{pid}/fd/{fd}") == str(target):
                    with open(f"/proc/{pid}/fdinfo/{fd}") as f:
                        for line in f:
                            if line.startswith("pos:"):
                                return int(line.split()[1])
            except OSError:
                continue
    except OSError:
        pass
    return None


def run(folder: Path, can_path: Path, nmea_path: Path, offsets: dict[float, int], record: bool) -> None:
    out = folder / "OUT.mcap"
    cmd = [sys.executable, "-m", "edged.cli", "replay", str(can_path), str(nmea_path), "--no-zenoh", "--no-progress"]
    if record:
        cmd += ["--record", str(out)]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    peak_at: dict[float, tuple[int, int, float]] = {}  # hour -> (peak RSS so far, RSS, wall)
    peak = 0
    start_rss = None
    pending = sorted(offsets)
    last_pos = 0
    while proc.poll() is None:
        st = status(proc.pid)
        rss = st.get("VmRSS", 0)
        peak = max(peak, rss, st.get("VmHWM", 0))
        pos = _position(proc.pid, can_path)
        if pos is not None:
            last_pos = pos
            if start_rss is None and pos > 0:
                start_rss = rss
        while pending and last_pos >= offsets[pending[0]]:
            peak_at[pending.pop(0)] = (peak, rss, time.perf_counter() - t0)
        time.sleep(0.2)
    output = proc.stdout.read() if proc.stdout else ""
    wall = time.perf_counter() - t0
    for h in pending:  # read to the end between two samples
        peak_at[h] = (peak, 0, wall)
    hours = max(offsets) if offsets else 0
    label = "with --record" if record else "without --record"
    print(f"\nreplay {label}: {hours:g} h of data in {wall:.0f} s wall ({hours * 3600 / wall:.0f}x real time), exit {proc.returncode}")
    if start_rss:
        print(f"  RSS when reading began: {start_rss / 2**20:7.1f} MB")
    for h in sorted(peak_at):
        if h in MARKS or h == hours:
            p, r, w = peak_at[h]
            now = f", RSS then {r / 2**20:6.1f} MB" if r else ""
            print(f"  peak RSS at {h:5g} h of data: {p / 2**20:7.1f} MB{now} (wall {w:5.0f} s)")
    print(f"  peak RSS over the run:   {peak / 2**20:7.1f} MB")
    for line in output.splitlines():
        if line.startswith(("replayed", "output ")):
            print(f"  edged: {line}")
    if record:
        check_files(out)


def check_files(out: Path) -> None:
    from mcap.reader import make_reader

    files = [out]
    n = 1
    while (p := out.with_name(f"{out.stem}.{n:03d}{out.suffix}")).exists():
        files.append(p)
        n += 1
    total = 0
    for p in files:
        if not p.exists():
            print(f"  {p.name}: missing")
            continue
        with open(p, "rb") as f:
            summary = make_reader(f).get_summary()
        msgs = summary.statistics.message_count if summary and summary.statistics else 0
        total += msgs
        print(f"  {p.name}: {p.stat().st_size / 1e6:8.1f} MB, {len(summary.chunk_indexes) if summary else 0:6d} chunks, {msgs:9d} messages")
    print(f"  {len(files)} file(s), {total} messages recorded")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hours", type=float, default=24.0, help="hours of data (default 24)")
    ap.add_argument("--scale", type=float, default=0.45, help="fraction of the reference load's high-rate sensors")
    ap.add_argument("--no-record", action="store_true", help="also replay without --record (the baseline)")
    ap.add_argument("--keep", type=Path, help="write the logs and recordings here and keep them")
    a = ap.parse_args()
    folder = a.keep or Path(tempfile.mkdtemp(prefix="bench_memory_"))
    folder.mkdir(parents=True, exist_ok=True)
    try:
        t0 = time.perf_counter()
        can_path, nmea_path, offsets, lines = write_logs(folder, a.hours, a.scale)
        size = (can_path.stat().st_size + nmea_path.stat().st_size) / 1e6
        print(f"{a.hours:g} h of data at scale {a.scale:g}: {lines} lines ({lines / (a.hours * 3600):.0f}/s of data), "
              f"{size:.0f} MB, written in {time.perf_counter() - t0:.0f} s")
        run(folder, can_path, nmea_path, offsets, record=True)
        if a.no_record:
            run(folder, can_path, nmea_path, offsets, record=False)
    finally:
        if a.keep is None:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
