"""Hardening of `edged replay`'s command line (issue 10, "Exit codes and the word
'written'"): flags that cannot be true are refused at parsing, a `--record` target that
cannot be a file is bad usage, and SIGTERM / SIGINT stop a replay as they stop the
daemon (outputs drained and closed, summary printed, exit 1: it did not finish)."""

from __future__ import annotations

import functools
import operator
import os
import queue
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from edged.cli import build_parser, main

T0 = 1_732_350_000


def _cs(s: str) -> str:
    return f"{functools.reduce(operator.xor, s.encode(), 0):02X}"


def nmea_log(path: Path, seconds: int, times: list[float] | None = None) -> Path:
    """A TAG-stamped HDT log: one sentence a second of data (or at `times`)."""
    lines = []
    for i, t in enumerate(times if times is not None else [T0 + s for s in range(seconds)]):
        tag = f"c:{t:.3f}"
        body = f"GPHDT,{(i % 3600) / 10:.1f},T"
        lines.append(f"\\{tag}*{_cs(tag)}\\${body}*{_cs(body)}\r\n")
    path.write_text("".join(lines))
    return path


def _parse_exit(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(argv)
    return int(e.value.code), capsys.readouterr().err


# -- flags ----------------------------------------------------------------------
@pytest.mark.parametrize("date", ["2024-13-45", "2023-02-29", "2024-1-5", "20240105", "2024-W01-1", "yesterday", ""])
def test_a_date_that_is_not_a_day_is_refused_at_parsing(date, capsys):
    code, err = _parse_exit(["replay", "x.log", "--date", date], capsys)
    assert code == 2
    assert "--date" in err and "YYYY-MM-DD" in err


def test_a_real_date_passes_as_written():
    assert build_parser().parse_args(["replay", "x.log", "--date", "2024-02-29"]).date == "2024-02-29"


@pytest.mark.parametrize("speed", ["nan", "NaN", "inf", "-inf", "1e400", "fast"])
def test_a_speed_that_is_not_finite_is_refused_at_parsing(speed, capsys):
    code, err = _parse_exit(["replay", "x.log", f"--speed={speed}"], capsys)
    assert code == 2
    assert "--speed" in err and "finite" in err


def test_a_negative_speed_exits_2_naming_the_flag(tmp_path, capsys):
    log = nmea_log(tmp_path / "a.log", 3)
    assert main(["replay", str(log), "--speed", "-1", "--no-zenoh", "--no-progress"]) == 2
    assert "--speed" in capsys.readouterr().err


@pytest.mark.parametrize("speed", ["0", "1", "2.5", "100"])
def test_usable_speeds_pass(speed):
    assert build_parser().parse_args(["replay", "x.log", "--speed", speed]).speed == float(speed)


def test_a_bad_date_exits_2_before_anything_is_replayed(tmp_path, capsys):
    log = nmea_log(tmp_path / "a.log", 3)
    out = tmp_path / "out.mcap"
    code, err = _parse_exit(["replay", str(log), "--date", "2024-13-45", "--record", str(out)], capsys)
    assert code == 2 and "--date" in err
    assert not out.exists()


# -- --record targets that cannot be a file: bad usage ----------------------------
def test_record_into_an_existing_directory_exits_2_naming_it(tmp_path, capsys):
    log = nmea_log(tmp_path / "a.log", 3)
    folder = tmp_path / "already-here"
    folder.mkdir()
    assert main(["replay", str(log), "--no-zenoh", "--no-progress", "--record", str(folder)]) == 2
    err = capsys.readouterr().err
    assert f"--record {folder}: is a directory" in err
    assert len(err.strip().splitlines()) == 1
    assert list(folder.iterdir()) == []


def test_record_under_a_file_exits_2_naming_it(tmp_path, capsys):
    log = nmea_log(tmp_path / "a.log", 3)
    blocker = tmp_path / "plain-file"
    blocker.write_text("x")
    target = blocker / "sub" / "out.mcap"
    assert main(["replay", str(log), "--no-zenoh", "--no-progress", "--record", str(target)]) == 2
    err = capsys.readouterr().err
    assert f"--record {target}" in err and "not a directory" in err


def test_record_onto_something_that_is_not_a_regular_file_exits_2(tmp_path, capsys):
    # A FIFO: the recorder would block on it, or (failing) remove it.
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    log = nmea_log(tmp_path / "a.log", 3)
    proc = subprocess.run(
        [sys.executable, "-m", "edged.cli", "replay", str(log), "--no-zenoh", "--no-progress", "--record", str(fifo)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert proc.returncode == 2
    assert f"--record {fifo}: is not a regular file" in proc.stderr
    assert fifo.exists()


# -- SIGTERM / SIGINT ---------------------------------------------------------------
@pytest.mark.parametrize("group", [False, True], ids=["process", "group"])
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGQUIT, signal.SIGHUP])
def test_a_signal_stops_a_recording_replay_like_the_daemon(tmp_path, sig, group):
    """To the replay's process, or (issue 32) to its whole process group, as Ctrl-C in a
    terminal and `systemctl stop` do: the recorder's and the workers' processes ignore
    it and the parent finishes the file (before, the group signal killed the recorder
    first: the file was left unfinished). SIGQUIT (Ctrl-\\) and SIGHUP (the terminal
    closed) as well: before, either ended the replay at once, the file unfinished."""
    from mcap.reader import make_reader

    # Ten sentences at the first instant (replayed before the replay first waits),
    # then one a second for an hour at real time: the replay is certainly running
    # when the signal arrives.
    long = nmea_log(tmp_path / "voyage.log", 0, [T0] * 10 + [T0 + s for s in range(1, 3600)])
    out = tmp_path / "out.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-m", "edged.cli", "--log-level", "info", "replay", str(long),
         "--no-zenoh", "--no-progress", "--speed", "1", "--record", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
        start_new_session=group,  # its own group, so that the test is not in it
        # SIGHUP as a terminal leaves it, whatever this test runs under (`nohup make
        # test` would have it ignored, and a replay started so keeps ignoring it)
        preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_DFL),
    )
    lines: queue.Queue[str | None] = queue.Queue()

    def read_stderr() -> None:
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.put(line)
        lines.put(None)

    reader = threading.Thread(target=read_stderr, daemon=True)
    reader.start()
    seen: list[str] = []
    try:
        # Wait for the started line, not a sleep (bounded: a replay that never says
        # it started fails the test instead of hanging it).
        while True:
            line = lines.get(timeout=60)
            if line is None:
                raise AssertionError("replay ended before it started: " + "".join(seen))
            seen.append(line)
            if "event=replay-started" in line:
                break
        if group:
            os.killpg(proc.pid, sig)
        else:
            proc.send_signal(sig)
        proc.wait(timeout=30)  # the summary is far smaller than a pipe's buffer
        assert proc.stdout is not None
        stdout = proc.stdout.read()
        reader.join(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    while not lines.empty():
        line = lines.get_nowait()
        if line is not None:
            seen.append(line)
    stderr = "".join(seen)
    assert proc.returncode == 1, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr
    assert f"signal={sig.name}" in stderr
    assert f"replay interrupted at 2024-11-23T08:20:0" in stdout and f"by {sig.name}" in stdout
    assert "voyage" in stdout and "accepted" in stdout  # the per-source table
    rec_line = next(ln for ln in stdout.splitlines() if ln.startswith("output record:"))
    assert "0 dropped" in rec_line
    # The file is finished: its summary is there, and holds what was recorded.
    with open(out, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    topics = {c.topic for c in summary.channels.values()}
    assert {"/raw/nmea0183/voyage", "/meas/heading/voyage", "/health"} <= topics
    n = summary.statistics.message_count
    assert n >= 21 and f"{n} messages recorded" in rec_line  # 10 raw, 10 headings, health


def test_a_replay_started_under_nohup_goes_on_after_a_hangup(tmp_path):
    """Started with SIGHUP ignored (`nohup edged replay ...`), a hangup does not stop it:
    the SIGTERM after it does, and the summary names SIGTERM."""
    long = nmea_log(tmp_path / "voyage.log", 0, [T0] * 10 + [T0 + s for s in range(1, 3600)])
    proc = subprocess.Popen(
        [sys.executable, "-m", "edged.cli", "--log-level", "info", "replay", str(long),
         "--no-zenoh", "--no-progress", "--speed", "1", "--record", str(tmp_path / "out.mcap")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
        preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN),
    )
    try:
        assert proc.stderr is not None
        for line in proc.stderr:
            if "event=replay-started" in line:
                break
        proc.send_signal(signal.SIGHUP)
        proc.send_signal(signal.SIGTERM)
        stdout, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1
    assert "by SIGTERM" in stdout and "SIGHUP" not in stdout


# -- a closed standard output -------------------------------------------------------
def test_replay_summary_into_a_closed_pipe_is_one_line_not_a_traceback(tmp_path):
    log = nmea_log(tmp_path / "a.log", 5)
    r, w = os.pipe()
    os.close(r)  # the reader is gone before the first byte
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "edged.cli", "replay", str(log), "--no-zenoh", "--no-progress"],
            stdout=w,
            stderr=subprocess.PIPE,
            text=True,
            timeout=60,
        )
    finally:
        os.close(w)
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr and "Exception ignored" not in proc.stderr
    assert proc.stderr.strip().splitlines() == [
        "edged replay: standard output closed by its reader (broken pipe): output incomplete"
    ]


@pytest.mark.parametrize("duration", ["nan", "inf", "0", "-5"])
def test_a_demo_duration_that_cannot_be_waited_for_is_refused(duration, capsys):
    code, err = _parse_exit(["demo", f"--duration={duration}"], capsys)
    assert code == 2 and "--duration" in err


def test_a_demo_duration_in_seconds_passes():
    assert build_parser().parse_args(["demo", "--duration", "2.5"]).duration == 2.5


def test_any_plugin_command_into_a_closed_pipe_is_one_line_not_a_traceback(tmp_path):
    # `edged sim` has no guard of its own: the dispatcher's catches it.
    r, w = os.pipe()
    os.close(r)
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "edged.cli", "sim", "faults", "--out", str(tmp_path / "sim"), "--duration", "5"],
            stdout=w,
            stderr=subprocess.PIPE,
            text=True,
            timeout=60,
        )
    finally:
        os.close(w)
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr and "Exception ignored" not in proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == (
        "edged sim: standard output closed by its reader (broken pipe): output incomplete"
    )
