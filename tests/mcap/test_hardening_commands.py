"""Hardening of the recording commands (issue 10, "Exit codes and the word 'written'"
and "Damaged and foreign files"): a replay whose recorder could not write exits 1 and
says what reached the file; a closed standard output is one line, never a traceback;
export names an encoding it does not read."""

from __future__ import annotations

import errno
import functools
import io
import operator
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from edged.cli import build_parser, main as cli
from edged.commands import dispatch
from edged.registry import Registry
from edged_mcap.recorder import McapRecorder

T0 = 1_732_350_000


def _cs(s: str) -> str:
    return f"{functools.reduce(operator.xor, s.encode(), 0):02X}"


def nmea_log(path: Path, n: int) -> Path:
    """`n` TAG-stamped HDT sentences, ten a second of data."""
    lines = []
    for i in range(n):
        tag = f"c:{T0 + i / 10:.1f}"
        body = f"GPHDT,{(i % 3600) / 10:.1f},T"
        lines.append(f"\\{tag}*{_cs(tag)}\\${body}*{_cs(body)}\r\n")
    path.write_text("".join(lines))
    return path


def _messages(path: Path) -> int:
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    return summary.statistics.message_count


def _output_line(out: str) -> str:
    return next(ln for ln in out.splitlines() if ln.startswith("output record:"))


# -- replay --record: exit codes and what reached the file -----------------------------
def test_replay_record_summary_says_what_reached_the_file(tmp_path, capsys):
    log = nmea_log(tmp_path / "ship.log", 200)
    out = tmp_path / "again.mcap"
    assert cli(["replay", str(log), "--no-zenoh", "--no-progress", "--record", str(out)]) == 0
    line = _output_line(capsys.readouterr().out)
    n = _messages(out)
    assert f"{n} messages recorded, 0 dropped, 0 rejected, into {out}" in line
    assert "records handed over" in line and " written" not in line


class _FailingDisk:
    """Files that take `budget` bytes, then fail every write with EIO."""

    budget = 0

    def __call__(self, path: Path, mode: str) -> io.FileIO:
        disk = self

        class _File(io.FileIO):
            def write(self, b: Any) -> int:  # type: ignore[override]
                if disk.budget <= 0:
                    raise OSError(errno.EIO, "Input/output error")
                b = bytes(b)[: disk.budget]
                disk.budget -= len(b)
                return super().write(b)

        return _File(path, mode)


def _failing_registry(budget: int) -> Registry:
    disk = _FailingDisk()
    disk.budget = budget

    class FailingRecorder(McapRecorder):
        def __init__(self, config: Any, ctx: Any) -> None:
            super().__init__(config, ctx, opener=disk)

    reg = Registry()
    reg.register("outputs", "mcap", FailingRecorder)
    return reg


def test_replay_whose_recorder_fails_mid_replay_exits_1_naming_the_file(tmp_path, capsys):
    log = nmea_log(tmp_path / "ship.log", 3000)  # several 64 KiB chunks of data
    out = tmp_path / "again.mcap"
    argv = ["replay", str(log), "--no-zenoh", "--no-progress", "--record", str(out)]
    rc = dispatch(build_parser().parse_args(argv), _failing_registry(100_000))
    cap = capsys.readouterr()
    assert rc == 1
    said = [ln for ln in cap.err.splitlines() if ln.startswith("edged replay:")]
    assert len(said) == 1 and f"output record ({out})" in said[0] and "Input/output error" in said[0]
    line = _output_line(cap.out)
    handed = int(line.split(": ")[1].split()[0])
    recorded = int(line.split(", ")[1].split()[0])
    dropped = int(line.split(", ")[2].split()[0])
    # What the recorder could not confirm in the file is dropped, not "written".
    assert recorded < handed and dropped > 0 and recorded + dropped <= handed
    assert "dropped (failed" in line


def test_replay_whose_recording_cannot_even_start_exits_1(tmp_path, capsys):
    log = nmea_log(tmp_path / "ship.log", 50)
    out = tmp_path / "again.mcap"
    argv = ["replay", str(log), "--no-zenoh", "--no-progress", "--record", str(out)]
    rc = dispatch(build_parser().parse_args(argv), _failing_registry(0))
    cap = capsys.readouterr()
    assert rc == 1
    assert f"edged replay: output record ({out})" in cap.err
    assert "0 messages recorded" in _output_line(cap.out)


# -- a closed standard output ------------------------------------------------------------
@pytest.fixture
def recording(tmp_path) -> Path:
    log = nmea_log(tmp_path / "ship.log", 3000)
    out = tmp_path / "rec.mcap"
    assert cli(["replay", str(log), "--no-zenoh", "--no-progress", "--record", str(out)]) == 0
    return out


def _into_closed_pipe(*argv: str) -> subprocess.CompletedProcess[str]:
    r, w = os.pipe()
    os.close(r)  # the reader (`head`) is gone before the first byte
    try:
        return subprocess.run(
            [sys.executable, "-m", "edged.cli", *argv], stdout=w, stderr=subprocess.PIPE, text=True, timeout=60
        )
    finally:
        os.close(w)


@pytest.mark.parametrize(
    "command", [["inspect"], ["export", "--topic", "/meas/heading/ship"], ["export", "--topic", "/raw/nmea0183/ship", "--format", "jsonl"], ["recover"]]
)
def test_a_closed_stdout_is_one_line_never_a_traceback(recording, command):
    name, *rest = command
    proc = _into_closed_pipe(name, str(recording), *rest)
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr and "Exception ignored" not in proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == (
        f"edged {name}: standard output closed by its reader (broken pipe): output incomplete"
    )
    assert str(recording) not in proc.stderr  # the input is not to blame


@pytest.mark.skipif(not Path("/dev/full").is_char_device(), reason="needs /dev/full")
def test_export_write_error_names_the_output_not_the_input(recording, capsys):
    assert cli(["export", str(recording), "--topic", "/meas/heading/ship", "-o", "/dev/full"]) == 1
    err = capsys.readouterr().err
    assert "/dev/full: No space left on device" in err
    assert f"{recording}:" not in err
    assert Path("/dev/full").is_char_device()


def test_export_onto_its_own_input_is_refused(recording, capsys):
    before = recording.read_bytes()
    assert cli(["export", str(recording), "--topic", "/meas/heading/ship", "-o", str(recording)]) == 2
    assert "overwrite" in capsys.readouterr().err
    assert recording.read_bytes() == before


# -- a foreign recording ------------------------------------------------------------
@pytest.fixture
def ros2_recording(tmp_path) -> Path:
    """A tiny ROS 2 style recording: /chatter as CDR std_msgs/msg/String."""
    path = tmp_path / "ros2.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="test")
        sid = w.register_schema(name="std_msgs/msg/String", encoding="ros2msg", data=b"string data")
        cid = w.register_channel(topic="/chatter", message_encoding="cdr", schema_id=sid)
        for i in range(100):
            text = f"hello {i}".encode() + b"\x00"
            cdr = b"\x00\x01\x00\x00" + len(text).to_bytes(4, "little") + text
            w.add_message(channel_id=cid, log_time=(T0 + i) * 10**9, data=cdr, publish_time=(T0 + i) * 10**9)
        w.finish()
    return path


@pytest.mark.parametrize("fmt", ["csv", "jsonl"])
def test_export_names_an_encoding_edged_does_not_read(ros2_recording, tmp_path, capsys, fmt):
    out = tmp_path / "chatter.csv"
    rc = cli(["export", str(ros2_recording), "--topic", "/chatter", "--format", fmt, "-o", str(out)])
    err = capsys.readouterr().err
    assert rc == 2
    assert "no messages" not in err
    assert "'/chatter'" in err and "'cdr'" in err and "std_msgs/msg/String" in err and "'json'" in err
    assert not out.exists()


def test_inspect_still_lists_the_foreign_topic(ros2_recording, capsys):
    assert cli(["inspect", str(ros2_recording)]) == 0
    assert any(ln.split()[:3] == ["/chatter", "std_msgs/msg/String", "100"] for ln in capsys.readouterr().out.splitlines())
