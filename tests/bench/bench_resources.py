"""Benchmark: peak memory, wall time and exit of `edged` commands on hostile inputs (issue 32).

    .venv/bin/python tests/bench/bench_resources.py [--cases lines,mcap,files,draft]
        [--sizes 64M,512M] [--formats candump,ydwg,actisense,nmea] [--fill data|junk]
        [--extra candump:2G ...] [--mcap-sizes 64M,256M] [--mcap-chunks 2]
        [--compression zstd|lz4] [--mcap-fill message|zeros] [--files 100,250,1000]
        [--with-10k] [--drafts 2,5,10,12] [--timeout 600] [--rss-cap 12G] [--nofile N]
        [--work DIR] [--keep] [--out DIR]

Issue 32 ("Memory and cost that grow with the input") is about inputs whose cost is
not bounded by what a gateway computer has: a command that reads a file must not need
memory in proportion to one line of it, to what a chunk claims to inflate to, or to
the number of files named. Each class of hostile input is generated here at several
sizes, and the real command line (`python -m edged.cli ...`, a child process in a
session of its own) is run on it, one run at a time:

1. `lines`: a log of each text format with one huge line (no newline in it) in the
   middle, between a few thousand good lines (more than the 32 KiB the replay sniffs,
   so the file is recognised): candump (`(t) can0 ID#DATA`), Yacht Devices RAW
   (`hh:mm:ss.mmm R ID xx ...`), canboat/Actisense plain (`time,prio,pgn,...,xx,...`)
   and NMEA 0183 (RMC and GGA). `--fill data` (the default) starts the huge line like
   a line of its format and lets its data field run on (`#0000...`, ` 00 00 ...`,
   `,00,00...`, `,0,0...`): the worst case, each reader goes as far as it can with it;
   `--fill junk` makes it one repeated byte that matches nothing. A size of 0 is also
   run per format: the same log without the huge line, the command's baseline.
   Command: `edged replay --no-zenoh --no-progress FILE`.
2. `mcap`: a valid MCAP file (header, one schema and channel `/raw/nmea0183/gnss1`,
   `--mcap-chunks` chunks, data end, footer, no summary) whose every chunk inflates to
   nearly `--mcap-sizes` bytes (at most the reader's 1 GiB limit) and is a few KB on
   disk: `--mcap-fill message` repeats one recorded raw NMEA record (a GGA) as many
   times as fit, `zeros` is zero bytes (opcode-0 records of length 0). Commands:
   `edged inspect F`, `edged replay --no-zenoh --no-progress F`, `edged recover F`
   (writes F.recovered.mcap, removed after) and `edged export F --topic
   /raw/nmea0183/gnss1 --format jsonl -o /dev/null`.
3. `files`: N NMEA 0183 logs of one minute each (RMC and GGA every 10 s, valid
   checksums, each file the minute after the one before) on one command line,
   `edged replay --no-zenoh --no-progress f1 ... fN`, N from `--files` (10000 only
   with `--with-10k`: it may take very long). The `fds` column is the most file
   descriptors one process of the run held at once, against the soft `ulimit -n` the
   run had (`--nofile` sets it, e.g. 1024, the common default; else inherited).
4. `draft`: a configuration of K draft estimator instances (`[estimators.dK] type =
   "draft"`, `stw_from = ""`; 12 is the most the configuration allows), each in a
   process of its own by default, replaying `edged sim draft-harbour --duration 60`
   (its nmea.log and can.log) with `-c CONFIG`.

What is measured per run:
- `max 1 proc`: the largest peak RSS of any one process of the run, the kernel's own
  high-water mark (`ru_maxrss` of the run's `wait4`, which folds in the peaks of the
  children it reaped). It is the figure `getrusage(RUSAGE_CHILDREN).ru_maxrss` keeps,
  but per run: that one is a running maximum over every child so far, so its
  difference between two runs shows only a run that beats every earlier one. The
  script checks that RUSAGE_CHILDREN after each run is the maximum of its value
  before and this figure, and notes any run where it is not.
- `tree peak`: the largest sum of the resident memory (statm) of the run's process
  tree (the session's members and every descendant), sampled every 50 ms: what the
  machine had to hold at once when estimators or outputs run in child processes.
  Pages shared between processes count once per process, and a peak shorter than a
  sample can be missed: the one-process figure has no such gap.
- `procs`, `fds`: the most processes seen in the tree, and the most descriptors one
  of them held (sampled alike); `exit`: the exit code, `-SIG` for a signal, `timeout`
  when `--timeout` (default 600 s) ran out, `RSS cap` when the tree passed `--rss-cap`
  (default 12 GiB, so that the benchmark cannot take the machine; 0: no cap): both
  kill the run's whole session and are findings, not failures of the benchmark;
  `stderr`: its last lines (and its size when over 1 MB).

Generated inputs go to a fresh folder under `--work` (default: the system's temp
folder) and each big one is deleted as soon as its runs are done; everything is
removed at the end unless `--keep`. The table is printed (markdown) and, with `--out
DIR`, written to DIR/bench_resources.md. A default run (lines at 0, 64 MiB and 512 MiB
for four formats, MCAP chunks of 64 and 256 MiB, 100/250/1000 files, 2-12 drafts)
took 11 minutes with `--extra candump:2G` on the shared 2-core development machine;
`--mcap-sizes 64M,256M,1G` adds about 15 (the 1 GiB replay runs into the timeout).

Measured there on 2026-12-04 (`--extra candump:2G`, and `--mcap-sizes 64M,256M,1G`):
- at 9fba8e1, log readers reading whole lines: the replay's peak RSS for one huge line
  was about 5.6 times the line for candump (64 MiB: 479 MB, 512 MiB: 2.9 GB, 2 GiB:
  11.4 GB), about 110 times for YDWG RAW (64 MiB: 7.3 GB) and 150 times for Actisense
  plain (64 MiB: 10.0 GB), both past the 12 GiB cap at 512 MiB; NMEA 0183 stayed at its
  baseline (119 MB; 126 MB for the others). At 2b465b2, lines read with a bound: every
  format at its baseline up to 2 GiB, the line counted `rejected.too_long`.
- MCAP (the same at both; 1 GiB run at 2b465b2 only): about 3.7 times the inflated
  chunk in each of inspect, replay, recover and export (64 MiB: 279 MB, 256 MiB:
  1.0 GB, 1 GiB: 3.9 GB, from 192 KiB on disk); the replay of 2 x 1 GiB (15 million
  records) was still running after 600 s.
- N files: about 1.25 MB and one descriptor per file, all open at once (1000: 1.37 GB,
  1010 descriptors); with `--nofile 1024`, 1020 files end in exit 2, "Too many open
  files". K draft estimators: about 165 MB per instance in the tree (12: 2.09 GB).
- at 1a767a1 / 006545b (`--mcap-sizes 64M,256M,1G --timeout 300`; `--cases
  lines,files,draft --extra candump:2G --files 100,250,1000,3000`): MCAP chunks read in
  pieces: 48 MB in inspect and export, 51-52 MB in recover, 132 MB (192 MB tree) in
  replay, at every chunk size up to 1 GiB (the 2 x 1 GiB replay, 15 million records,
  still runs into the timeout: a matter of speed, issue 34). Files opened at their
  first record and closed at their end, health without the finished ones, workers
  given health as a time beacon: 100 / 250 / 1000 / 3000 files 122 / 132 / 132 / 146
  MB and 11-14 descriptors (2.7 / 4.9 / 18.5 / 75 s: the estimators' cost per second
  of data, 60 s per file). Lines and drafts as before.

Not a pytest test (no `test_` prefix): run it on demand.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import zlib
from dataclasses import dataclass, field
from functools import reduce
from operator import xor
from pathlib import Path

from procstat import rss as _rss, tree  # noqa: E402  (this folder)
from benchargs import names_of  # noqa: E402  (this folder)
from typing import BinaryIO, Callable, Sequence

EDGED = [sys.executable, "-m", "edged.cli"]
T0 = 1_732_350_000.0  # 2024-11-23 08:20:00 UTC
KiB, MiB, GiB = 1 << 10, 1 << 20, 1 << 30
SAMPLE_S = 0.05
#: Good lines before and after the huge line: more than the 32 KiB the replay sniffs.
AROUND_LINES = 2000
#: The reader's limit on a chunk's uncompressed size (edged_mcap.reading.MAX_RECORD).
MCAP_LIMIT = GiB
MCAP_TOPIC = "/raw/nmea0183/gnss1"
_WRITE_BLOCK = 16 * MiB


# -- sizes --------------------------------------------------------------------------
_SIZE = re.compile(r"(\d+(?:\.\d+)?)\s*([KMG]?)i?B?", re.IGNORECASE)


def parse_size(text: str) -> int:
    """`64M`, `1.5G`, `512k`, `1000` -> bytes (binary units: M is MiB)."""
    m = _SIZE.fullmatch(text.strip())
    if m is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not a size such as 64M or 2G")
    scale = {"": 1, "K": KiB, "M": MiB, "G": GiB}[m.group(2).upper()]
    return int(float(m.group(1)) * scale)


def sizes(text: str) -> list[int]:
    return [parse_size(s) for s in text.split(",") if s.strip()]


def counts(text: str) -> list[int]:
    try:
        return [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a list of whole numbers") from None


def label(n: int) -> str:
    """Bytes in the unit that reads best: `512 MiB`, `2 GiB`, `94 KiB`."""
    for unit, scale in (("GiB", GiB), ("MiB", MiB), ("KiB", KiB)):
        if n >= scale:
            v = n / scale
            return f"{v:.0f} {unit}" if abs(v - round(v)) < 0.05 else f"{v:.1f} {unit}"
    return f"{n} B"


def mb(n: int | None) -> str:
    return "-" if n is None else f"{n / MiB:,.0f}"


# -- one run, measured ----------------------------------------------------------------
@dataclass
class Run:
    """One command on one input, as the table shows it."""

    case: str
    size: str
    command: str
    exit: str = ""
    wall: float = 0.0
    max_one: int | None = None  # bytes: ru_maxrss of the run's wait4
    tree_peak: int = 0  # bytes: largest sampled sum over the tree
    procs: int = 0
    fds: int = 0
    nofile: int = 0
    stderr: str = ""
    notes: list[str] = field(default_factory=list)


def _fds(pid: int) -> int:
    try:
        return len(os.listdir(f"/proc/{pid}/fd"))
    except OSError:
        return 0


def _tail(path: Path, lines: int = 3, width: int = 220) -> str:
    """The last non-empty lines of a (maybe huge) file, each cut to `width`."""
    size = path.stat().st_size
    with path.open("rb") as f:
        f.seek(max(0, size - 16 * KiB))
        text = f.read().decode("utf-8", "replace")
    rows = [ln.strip() for ln in text.splitlines() if ln.strip()][-lines:]
    rows = [r if len(r) <= width else r[: width - 1] + "…" for r in rows]
    out = " ⏎ ".join(rows)
    if size > MiB:
        out = f"({label(size)} of stderr) " + out
    return out


def _kill(pgid: int) -> None:
    """SIGKILL the run's session group (the processes this benchmark started)."""
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def _cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().replace(b"\0", b" ").decode("utf-8", "replace").strip()[:80]
    except OSError:
        return "?"


def _left_behind(run: Run, leader: int, grace: float = 3.0) -> None:
    """Processes of the run still alive `grace` s after it ended (a worker or
    multiprocessing's resource tracker that outlived it) are noted and killed."""
    deadline = time.perf_counter() + grace
    while (left := tree(leader)) and time.perf_counter() < deadline:
        time.sleep(SAMPLE_S)
    if left:
        names = "; ".join(sorted({_cmdline(p) for p in left}))
        run.notes.append(f"{len(left)} process(es) still alive {grace:g} s after the run ended, killed: {names}")
        _kill(leader)
        for p in left:  # a descendant that left the session
            try:
                os.kill(p, signal.SIGKILL)
            except ProcessLookupError:
                pass


def measure(run: Run, argv: Sequence[str], *, cwd: Path, timeout: float, rss_cap: int,
            nofile: int | None) -> Run:
    """Run `edged ARGV` in a session of its own, sample its tree until it ends, fill in `run`."""
    env = dict(os.environ)
    for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env.setdefault(v, "1")  # one core per job: the machine is shared
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    run.nofile = nofile if nofile else soft

    def limits() -> None:  # in the child, before exec
        if nofile:
            resource.setrlimit(resource.RLIMIT_NOFILE, (nofile, hard))

    err_path, out_path = cwd / "run.stderr", cwd / "run.stdout"
    ru_before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    with err_path.open("wb") as err, out_path.open("wb") as out:
        t0 = time.perf_counter()
        proc = subprocess.Popen([*EDGED, *argv], cwd=cwd, stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                                env=env, start_new_session=True, preexec_fn=limits if nofile else None)
        killed = ""
        try:
            while True:
                pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
                if pid:
                    break
                procs = tree(proc.pid)
                total = 0
                for p in procs:
                    total += _rss(p)
                    run.fds = max(run.fds, _fds(p))
                run.tree_peak = max(run.tree_peak, total)
                run.procs = max(run.procs, len(procs))
                if time.perf_counter() - t0 > timeout:
                    killed = f"timeout ({timeout:.0f} s)"
                elif rss_cap and total > rss_cap:
                    killed = f"RSS cap ({label(rss_cap)})"
                if killed:
                    _kill(proc.pid)
                    pid, status, usage = os.wait4(proc.pid, 0)
                    break
                time.sleep(SAMPLE_S)
        except BaseException:  # the benchmark stopped (Ctrl-C, SIGTERM): the run goes with it
            _kill(proc.pid)
            os.wait4(proc.pid, 0)
            raise
        run.wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here: Popen must not wait again
    _left_behind(run, proc.pid)
    run.max_one = usage.ru_maxrss * KiB  # Linux: kilobytes
    ru_after = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    if ru_after != max(ru_before, usage.ru_maxrss):
        run.notes.append(f"RUSAGE_CHILDREN ru_maxrss went {ru_before} -> {ru_after} kB, "
                         f"wait4 said {usage.ru_maxrss} kB")
    code = proc.returncode
    if killed:
        run.exit = killed
    elif code < 0:
        try:
            run.exit = f"-{signal.Signals(-code).name}"
        except ValueError:
            run.exit = str(code)
        if code == -signal.SIGKILL:
            run.notes.append("SIGKILL not sent by the benchmark: the kernel's OOM killer?")
    else:
        run.exit = str(code)
    run.stderr = _tail(err_path)
    if "Too many open files" in run.stderr:
        run.notes.append(f"needed more file descriptors than its limit ({run.nofile}): EMFILE")
    elif run.fds >= run.nofile - 3:
        run.notes.append(f"file descriptors: {run.fds} held, the limit is {run.nofile}")
    err_path.unlink()
    out_path.unlink()
    return run


# -- line formats ---------------------------------------------------------------------
def _checksummed(body: str) -> str:
    return f"${body}*{reduce(xor, body.encode(), 0):02X}"


def _hms(t: float) -> str:
    tm = time.gmtime(t)
    return f"{tm.tm_hour:02d}{tm.tm_min:02d}{tm.tm_sec:02d}.{int(round(t % 1 * 100)) % 100:02d}"


def rmc_gga(t: float) -> tuple[str, str]:
    """An RMC (it carries the date) and a GGA at time `t`, checksummed, no line end: a
    vessel at rest (one position, SOG 0), so that the estimators have nothing to
    complain about and stderr shows what the input itself caused."""
    hms = _hms(t)
    date = time.strftime("%d%m%y", time.gmtime(t))
    pos = "6005.0000,N,02330.0000,E"
    return (_checksummed(f"GPRMC,{hms},A,{pos},0.0,0.0,{date},,,A"),
            _checksummed(f"GPGGA,{hms},{pos},1,10,0.8,3.0,M,18.0,M,,"))


def _tod(t: float) -> str:
    tm = time.gmtime(t)
    return f"{tm.tm_hour:02d}:{tm.tm_min:02d}:{tm.tm_sec:02d}.{int(t % 1 * 1000):03d}"


def _iso(t: float) -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(t)) + f".{int(t % 1 * 1000):03d}Z"


#: PGN 126992 System Time of T0's day (days 20050, 30000 s): gives a YDWG log its date.
_SYSTEM_TIME = "0DF01023 00 F0 52 4E 00 A3 E1 11"


@dataclass(frozen=True)
class LineFormat:
    """A text log format: its good lines, and how its huge line begins and runs on."""

    name: str
    suffix: str
    line: Callable[[int], str]  # the i-th good line (no line end)
    start: Callable[[float], str]  # the huge line's beginning, at time t
    token: bytes  # what its data field repeats
    eol: bytes = b"\n"


def _step(i: int) -> float:
    return T0 + i * 0.01


FORMATS: dict[str, LineFormat] = {
    "candump": LineFormat(
        "candump", ".log",
        lambda i: f"({_step(i):.6f}) can0 09F80128#0102030405060708",
        lambda t: f"({t:.6f}) can0 09F80128#", b"00"),
    "ydwg": LineFormat(
        "ydwg", ".txt",
        lambda i: f"{_tod(_step(i))} R " + (_SYSTEM_TIME if i == 0 else "09F80128 01 02 03 04 05 06 07 08"),
        lambda t: f"{_tod(t)} R 09F80128", b" 00", b"\r\n"),
    "actisense": LineFormat(
        "actisense", ".txt",
        lambda i: f"{_iso(_step(i))},2,129025,40,255,8,01,02,03,04,05,06,07,08",
        lambda t: f"{_iso(t)},2,129025,40,255,8", b",00"),
    "nmea": LineFormat(
        "nmea", ".nmea",
        lambda i: rmc_gga(T0 + (i // 2) * 0.1)[i % 2],
        lambda t: f"$GPGGA,{_hms(t)}", b",0", b"\r\n"),
}


def _repeat(f: BinaryIO, token: bytes, n: int) -> None:
    """Write `token` n times, a block at a time (never the whole line in memory)."""
    block = token * max(1, _WRITE_BLOCK // len(token))
    per = len(block) // len(token)
    for _ in range(n // per):
        f.write(block)
    f.write(token * (n % per))


def write_huge_line_log(path: Path, fmt: LineFormat, size: int, fill: str) -> int:
    """AROUND_LINES good lines, one line of about `size` bytes without a newline in
    it (none when 0), AROUND_LINES good lines after; returns the file's size."""
    with path.open("wb") as f:
        for i in range(AROUND_LINES):
            f.write(fmt.line(i).encode() + fmt.eol)
        if size:
            start = fmt.start(_step(AROUND_LINES)).encode() if fill == "data" else b""
            token = fmt.token if fill == "data" else b"x"
            f.write(start)
            _repeat(f, token, max(0, size - len(start)) // len(token))
            f.write(fmt.eol)
        for i in range(AROUND_LINES + 1, 2 * AROUND_LINES + 1):
            f.write(fmt.line(i).encode() + fmt.eol)
    return path.stat().st_size


# -- MCAP with chunks that inflate ---------------------------------------------------
@dataclass
class McapInput:
    path: Path
    chunk_size: int  # uncompressed bytes per chunk
    records: int  # per chunk
    on_disk: int


def _compressed(record: bytes, n: int, compression: str) -> tuple[bytes, int]:
    """`record` * n compressed as one chunk's data, and its CRC32, streamed a block
    at a time so that the benchmark never holds the inflated chunk."""
    per = max(1, MiB // len(record))
    block = record * per
    parts: list[bytes] = []
    if compression == "zstd":
        import zstandard

        c = zstandard.ZstdCompressor(level=3).compressobj(size=n * len(record))
        feed, end = c.compress, c.flush
    else:
        import lz4.frame

        c = lz4.frame.LZ4FrameCompressor()
        parts.append(c.begin(source_size=n * len(record)))
        feed, end = c.compress, c.flush
    crc = 0
    for _ in range(n // per):
        parts.append(feed(block))
        crc = zlib.crc32(block, crc)
    rest = record * (n % per)
    parts.append(feed(rest))
    crc = zlib.crc32(rest, crc)
    parts.append(end())
    return b"".join(parts), crc


def write_mcap(path: Path, chunk_size: int, chunks: int, compression: str, fill: str) -> McapInput:
    """A finished MCAP file (no summary) of `chunks` identical chunks, each inflating to
    nearly `chunk_size` bytes (at most the reader's limit): one raw NMEA record
    repeated, or zero bytes."""
    from mcap.data_stream import RecordBuilder
    from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Message, Schema

    ns = int(T0 * 1e9)
    b = RecordBuilder()
    if fill == "message":
        payload = json.dumps({"t": T0, "line": rmc_gga(T0)[1], "meta": None}).encode()
        Message(channel_id=1, log_time=ns, data=payload, publish_time=ns, sequence=0).write(b)
        record = b.end()
    else:
        record = bytes(9)  # opcode 0, length 0: a record no reader knows, skipped
    n = min(chunk_size, MCAP_LIMIT) // len(record)
    data, crc = _compressed(record, n, compression)
    with path.open("wb") as f:
        f.write(b"\x89MCAP0\r\n")
        Header(profile="", library="bench_resources").write(b)
        Schema(id=1, name="edged.raw.nmea0183", encoding="jsonschema", data=b"{}").write(b)
        Channel(id=1, topic=MCAP_TOPIC, message_encoding="json", metadata={}, schema_id=1).write(b)
        f.write(b.end())
        for _ in range(chunks):
            Chunk(compression=compression, data=data, message_start_time=ns, message_end_time=ns,
                  uncompressed_crc=crc, uncompressed_size=n * len(record)).write(b)
            f.write(b.end())
        DataEnd(data_section_crc=0).write(b)
        Footer(summary_start=0, summary_offset_start=0, summary_crc=0).write(b)
        f.write(b.end())
        f.write(b"\x89MCAP0\r\n")
    return McapInput(path, n * len(record), n, path.stat().st_size)


# -- many small files and many estimators ---------------------------------------------
def write_many_nmea(folder: Path, n: int) -> list[Path]:
    """N one-minute NMEA 0183 logs, file j holding minute j: RMC + GGA every 10 s."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for j in range(n):
        p = folder / f"gnss-{j:05d}.nmea"
        t = T0 + 60.0 * j
        p.write_bytes(b"".join(f"{s}\r\n".encode() for k in range(6) for s in rmc_gga(t + 10.0 * k)))
        paths.append(p)
    return paths


def draft_config(path: Path, k: int) -> Path:
    path.write_text("".join(f'[estimators.d{i}]\ntype = "draft"\nstw_from = ""\n\n' for i in range(1, k + 1)))
    return path


# -- the cases ------------------------------------------------------------------------
@dataclass
class Bench:
    """What every case needs: the options, the work folder, the rows so far."""

    args: argparse.Namespace
    work: Path
    runs: list[Run] = field(default_factory=list)

    def run(self, case: str, size: str, argv: Sequence[str], shown: str) -> Run:
        r = measure(Run(case, size, shown), argv, cwd=self.work, timeout=self.args.timeout,
                    rss_cap=self.args.rss_cap, nofile=self.args.nofile)
        self.runs.append(r)
        print(f"  {case} {size}: `{shown}` exit {r.exit}, {r.wall:.1f} s, max 1 proc {mb(r.max_one)} MB, "
              f"tree {mb(r.tree_peak)} MB" + (f" [{'; '.join(r.notes)}]" if r.notes else ""),
              file=sys.stderr, flush=True)
        return r

    def drop(self, *paths: Path) -> None:
        """Delete a generated input now (unless --keep): the next may be as big."""
        if self.args.keep:
            return
        for p in paths:
            if p.is_dir():
                shutil.rmtree(p, ignore_errors=True)
            else:
                p.unlink(missing_ok=True)


REPLAY = ["replay", "--no-zenoh", "--no-progress"]


def case_lines(bench: Bench) -> None:
    a = bench.args
    plan: list[tuple[str, int]] = [(f, s) for f in a.formats for s in [0, *a.sizes]]
    plan += [(f, s) for f, s in a.extra if (f, s) not in plan]
    for name, size in plan:
        fmt = FORMATS[name]
        path = bench.work / f"{name}-{label(size).replace(' ', '') if size else 'no-huge-line'}{fmt.suffix}"
        t = time.perf_counter()
        total = write_huge_line_log(path, fmt, size, a.fill)
        what = f"{label(size)} line" if size else "no huge line"
        print(f"{name}: {what}, file {label(total)} written in {time.perf_counter() - t:.0f} s",
              file=sys.stderr, flush=True)
        bench.run(f"line: {name}", what, [*REPLAY, path.name], shlex.join([*REPLAY, path.name]))
        bench.drop(path)


def case_mcap(bench: Bench) -> None:
    a = bench.args
    for size in a.mcap_sizes:
        path = bench.work / f"inflate-{label(size).replace(' ', '')}.mcap"
        t = time.perf_counter()
        m = write_mcap(path, size, a.mcap_chunks, a.compression, a.mcap_fill)
        what = f"{a.mcap_chunks} × {label(m.chunk_size)} ({a.compression}, {label(m.on_disk)} on disk)"
        print(f"mcap: {what}, {m.records:,} records per chunk, written in {time.perf_counter() - t:.0f} s",
              file=sys.stderr, flush=True)
        f = path.name
        for argv in (["inspect", f], [*REPLAY, f], ["recover", f],
                     ["export", f, "--topic", MCAP_TOPIC, "--format", "jsonl", "-o", "/dev/null"]):
            bench.run(f"mcap: {argv[0]}", what, argv, shlex.join(argv))
            bench.drop(path.with_name(path.stem + ".recovered.mcap"))
        bench.drop(path)


def case_files(bench: Bench) -> None:
    a = bench.args
    for n in [*a.files, *([10_000] if a.with_10k and 10_000 not in a.files else [])]:
        folder = bench.work / f"files-{n}"
        paths = write_many_nmea(folder, n)
        names = [str(p.relative_to(bench.work)) for p in paths]
        shown = shlex.join([*REPLAY, names[0]]) + (f" … {names[-1]}" if n > 1 else "")
        bench.run("many files: nmea", f"N = {n}", [*REPLAY, *names], shown)
        bench.drop(folder)


def case_draft(bench: Bench) -> None:
    a = bench.args
    sim = bench.work / "draft-sim"
    p = subprocess.run([*EDGED, "sim", "draft-harbour", "--duration", f"{a.draft_duration:g}", "--out", str(sim)],
                       capture_output=True, text=True)
    if p.returncode != 0:
        print(f"draft: `edged sim draft-harbour` failed ({p.returncode}): {p.stderr[-500:]}", file=sys.stderr)
        bench.runs.append(Run("draft estimators", "-", "sim draft-harbour", exit=f"sim failed: {p.returncode}",
                              stderr=p.stderr.strip().splitlines()[-1] if p.stderr.strip() else ""))
        return
    for k in a.drafts:
        cfg = draft_config(bench.work / f"drafts-{k}.toml", k)
        argv = ["replay", "-c", cfg.name, "--no-zenoh", "--no-progress", "draft-sim/nmea.log", "draft-sim/can.log"]
        bench.run("draft estimators", f"K = {k}", argv, shlex.join(argv))
        bench.drop(cfg)
    bench.drop(sim)


CASES: dict[str, Callable[[Bench], None]] = {
    "lines": case_lines, "mcap": case_mcap, "files": case_files, "draft": case_draft,
}


# -- the report -----------------------------------------------------------------------
def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def table(runs: Sequence[Run]) -> str:
    head = ["case", "input", "command (`edged` …)", "exit", "wall s", "max 1 proc MB", "tree peak MB",
            "procs", "fds / ulimit -n", "stderr (last lines)"]
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in runs:
        cells = [r.case, r.size, f"`{r.command}`", r.exit, f"{r.wall:.1f}", mb(r.max_one), mb(r.tree_peak),
                 str(r.procs), f"{r.fds} / {r.nofile}", r.stderr or "-"]
        rows.append("| " + " | ".join(_cell(c) for c in cells) + " |")
    return "\n".join(rows)


def _machine() -> str:
    """Cores, memory and load at the start: on a shared machine the wall times and
    the room left for a big run depend on them."""
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            kib = {k: int(v.split()[0]) for k, _, v in (ln.partition(":") for ln in f)}
        mem = f", {kib['MemTotal'] / 2**20:.0f} GiB RAM ({kib['MemAvailable'] / 2**20:.0f} available)"
    except (OSError, KeyError, ValueError, IndexError):
        pass
    load = " / ".join(f"{x:.1f}" for x in os.getloadavg())
    return f"{os.cpu_count()} cores{mem}, load average {load} at the start"


def _commit() -> str:
    """The checkout's commit, and whether tracked files differ from it: what the
    table measured. Read only (GIT_OPTIONAL_LOCKS=0: `git status` does not even
    refresh the index)."""
    env = {**os.environ, "GIT_OPTIONAL_LOCKS": "0"}
    here = Path(__file__).resolve().parent
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=here, env=env, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                               text=True, cwd=here, env=env, timeout=30).stdout.splitlines()
    except (OSError, subprocess.SubprocessError):
        return "?"
    return (head or "?") + (f" with {len(dirty)} changed tracked file(s)" if dirty else "")


def report(runs: Sequence[Run], started: str, commit: str, machine: str, wall: float, argv: Sequence[str]) -> str:
    now = _commit()
    moved = "" if now == commit else f" (HEAD moved to {now} during the run: later rows may measure newer code)"
    lines = [
        "# bench_resources: peak RSS of `edged` on hostile inputs (issue 32)",
        "",
        f"{started}, commit {commit}{moved}, {machine}; total wall time {wall / 60:.1f} min.",
        f"Command: `{shlex.join([Path(sys.executable).name, 'tests/bench/bench_resources.py', *argv])}`",
        "",
        table(runs),
        "",
        "max 1 proc: the largest peak RSS of one process of the run (ru_maxrss of its wait4); tree peak: "
        f"the largest sampled sum of RSS over the run's processes (every {SAMPLE_S * 1000:.0f} ms); "
        "fds: the most descriptors one process held (sampled), against its soft limit. "
        "Exit `RSS cap`: killed when the tree passed the cap, its true peak is higher; `timeout`: killed "
        "after --timeout, the peaks are those reached by then.",
    ]
    notes = [f"- {r.case} {r.size} `{r.command}`: {n}" for r in runs for n in r.notes]
    if notes:
        lines += ["", "Notes:", *notes]
    return "\n".join(lines) + "\n"


# -- main -----------------------------------------------------------------------------
def _extra(text: str) -> tuple[str, int]:
    name, sep, size = text.partition(":")
    if not sep or name not in FORMATS:
        raise argparse.ArgumentTypeError(f"{text!r}: give FORMAT:SIZE with FORMAT one of {', '.join(FORMATS)}")
    return name, parse_size(size)


def _interrupt(signum: int, frame: object) -> None:
    """SIGTERM as Ctrl-C: the current run is killed, inputs removed, the table printed."""
    raise KeyboardInterrupt(f"signal {signum}")


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--cases", type=names_of(list(CASES)), default=",".join(CASES), help="classes of input to run")
    ap.add_argument("--sizes", type=sizes, default="64M,512M", help="huge line sizes (0 always runs too)")
    ap.add_argument("--formats", type=names_of(list(FORMATS)), default=",".join(FORMATS),
                    help="text formats for the huge line")
    ap.add_argument("--fill", choices=("data", "junk"), default="data",
                    help="huge line: its format's data field running on, or one repeated byte")
    ap.add_argument("--extra", type=_extra, action="append", default=[], metavar="FORMAT:SIZE",
                    help="one more huge line size for one format (repeatable), e.g. candump:2G")
    ap.add_argument("--mcap-sizes", type=sizes, default="64M,256M",
                    help="uncompressed bytes per chunk (at most 1G: the reader's limit)")
    ap.add_argument("--mcap-chunks", type=int, default=2, help="chunks per MCAP file")
    ap.add_argument("--compression", choices=("zstd", "lz4"), default="zstd")
    ap.add_argument("--mcap-fill", choices=("message", "zeros"), default="message",
                    help="chunk content: one raw NMEA record repeated, or zero bytes")
    ap.add_argument("--files", type=counts, default="100,250,1000", help="numbers of NMEA files")
    ap.add_argument("--with-10k", action="store_true", help="also 10000 files (may take very long)")
    ap.add_argument("--drafts", type=counts, default="2,5,10,12", help="draft estimator instances")
    ap.add_argument("--draft-duration", type=float, default=60.0, help="seconds of draft-harbour to replay")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per run before it is killed")
    ap.add_argument("--rss-cap", type=parse_size, default="12G",
                    help="kill a run whose tree's RSS passes this (0: no cap)")
    ap.add_argument("--nofile", type=int, default=None, help="soft `ulimit -n` of each run (none: inherited)")
    ap.add_argument("--work", type=Path, default=Path(tempfile.gettempdir()), help="folder for the generated inputs")
    ap.add_argument("--keep", action="store_true", help="keep the generated inputs")
    ap.add_argument("--out", type=Path, default=None, help="also write the table to DIR/bench_resources.md")
    a = ap.parse_args(argv)
    a.work.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="bench_resources-", dir=a.work))
    bench = Bench(a, work)
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    commit, machine = _commit(), _machine()
    t0 = time.perf_counter()
    signal.signal(signal.SIGTERM, _interrupt)  # (a background job ignores SIGINT)
    try:
        for name in a.cases:
            CASES[name](bench)
    except KeyboardInterrupt:
        print("interrupted: the table holds the runs done so far", file=sys.stderr)
    finally:
        if a.keep:
            print(f"inputs kept in {work}", file=sys.stderr)
        else:
            shutil.rmtree(work, ignore_errors=True)
    text = report(bench.runs, started, commit, machine, time.perf_counter() - t0,
                  sys.argv[1:] if argv is None else argv)
    print(text)
    if a.out is not None:
        a.out.mkdir(parents=True, exist_ok=True)
        (a.out / "bench_resources.md").write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
