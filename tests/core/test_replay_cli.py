"""Replay through the core driver and the CLI's exit codes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from core_dummies import ListOutput

from edged.cli import build_parser, main
from edged.commands import dispatch
from edged.records import Estimate, Measurement, RawRecord

CFG = """
[estimators.sum]
type = "sum"
[estimators.chain]
type = "chain"
[outputs.rec]
type = "list"
"""


def _run(registry, *argv: str) -> int:
    return dispatch(build_parser().parse_args(list(argv)), registry)


@pytest.fixture
def logs(tmp_path: Path) -> tuple[Path, Path]:
    a = tmp_path / "gyro.log"
    a.write_text("#dummy\n1.0 yaw_rate r=1\n3.0 yaw_rate r=2\nnot-a-time x\n5.0 yaw_rate r=4\n")
    b = tmp_path / "imu.log"
    b.write_text("#dummy\n2.0 yaw_rate r=10\n4.0 yaw_rate garbage\n6.0 heading heading=1\n")
    return a, b


def _replay(registry, write_config, logs, *extra: str) -> list:
    cfg = write_config(CFG)
    ListOutput.instances.clear()
    rc = _run(registry, "replay", str(logs[0]), str(logs[1]), "-c", str(cfg), "--no-zenoh", "--no-progress", *extra)
    assert rc == 0
    return ListOutput.instances[0].records


def test_replay_merges_files_in_time_order_and_summarises(registry, write_config, logs, capsys):
    recs = _replay(registry, write_config, logs)
    raws = [r for r in recs if isinstance(r, RawRecord)]
    assert [r.t for r in raws] == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    meas = [r for r in recs if isinstance(r, Measurement)]
    assert [(m.source, m.t) for m in meas] == [
        ("gyro", 1.0), ("imu", 2.0), ("gyro", 3.0), ("gyro", 5.0), ("imu", 6.0)
    ]
    sums = [r.values["total"] for r in recs if isinstance(r, Estimate) and r.name == "sum"]
    assert sums == [1.0, 11.0, 13.0, 17.0]
    out = capsys.readouterr().out
    assert "replayed 6 records, 5.0 s of data" in out
    assert "rejected.no_time" in out and "rejected.syntax" in out
    assert any(line.split() == ["imu", "heading", "1"] for line in out.splitlines())


def test_replay_is_deterministic_at_any_speed(registry, write_config, logs):
    def estimates(*extra: str) -> dict[str, list]:
        # Each estimator's stream, in order (streams of different estimators interleave
        # at an output as the workers happen to run; each stream's order is the data's).
        out: dict[str, list] = {}
        for r in _replay(registry, write_config, logs, *extra):
            if isinstance(r, Estimate):
                out.setdefault(r.name, []).append((r.t, r.values))
        return out

    fast = estimates()
    assert fast == estimates("--speed", "50")
    chain = [v["trace"] for _, v in fast["chain"]]
    # a measurement first, then what the upstream worker made of it
    assert chain[-1] == "yeyeyeye"


def test_replay_unknown_format_and_missing_file_exit_2(registry, tmp_path, capsys):
    junk = tmp_path / "junk.bin"
    junk.write_bytes(b"\x00\x01garbage")
    assert _run(registry, "replay", str(junk), "--no-zenoh", "--no-progress") == 2
    assert f"{junk}: format not recognised" in capsys.readouterr().err
    assert _run(registry, "replay", str(tmp_path / "nope.log"), "--no-zenoh") == 2
    assert "no such file" in capsys.readouterr().err


def test_replay_negative_speed_is_usage_error(registry, logs, capsys):
    assert _run(registry, "replay", str(logs[0]), "--speed", "-1", "--no-zenoh") == 2


def test_replay_record_without_recorder_plugin_is_usage_error(registry, logs, capsys):
    assert _run(registry, "replay", str(logs[0]), "--no-zenoh", "--record", "x.mcap") == 2
    assert "--record" in capsys.readouterr().err


def test_command_without_plugin_exits_1(registry, capsys):
    assert _run(registry, "inspect", "x.mcap") == 1
    assert "not available" in capsys.readouterr().err


def test_version_and_usage_exit_codes(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and "edged" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        main(["frobnicate"])
    assert e.value.code == 2
    with pytest.raises(SystemExit) as e:
        main(["replay"])
    assert e.value.code == 2
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    helptext = capsys.readouterr().out
    for cmd in ("run", "demo", "replay", "sim", "inspect", "export", "plot", "recover", "router", "fleet", "check-config"):
        assert cmd in helptext


def test_daemon_process_stops_on_sigterm_with_exit_0(tmp_path):
    cfg = tmp_path / "empty.toml"
    cfg.write_text('[edged]\nvessel_id = "proc-test"\n')
    proc = subprocess.Popen(
        [sys.executable, "-m", "edged.cli", "run", "-c", str(cfg)],
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        for line in proc.stderr:  # wait for the started line, not a sleep
            if "event=started" in line:
                break
        else:
            raise AssertionError("daemon never started")
        proc.send_signal(signal.SIGTERM)
        rest = proc.stderr.read()
        assert proc.wait(timeout=10) == 0
        assert "event=stopped" in rest
    finally:
        if proc.poll() is None:
            proc.kill()


def test_a_replay_whose_core_fails_on_every_record_ends_with_exit_1(registry, write_config, tmp_path, capsys):
    log = tmp_path / "gyro.log"
    log.write_text("#dummy\n" + "".join(f"{i}.0 yaw_rate r=7\n" for i in range(1, 200)))
    # a small queue: the replay feeds it a few records at a time, so the core fails many times
    cfg = write_config('[estimators.sum]\ntype = "sum"\nfail_on = 7.0\nqueue_size = 8\n[outputs.rec]\ntype = "list"\n')
    ListOutput.instances.clear()
    assert _run(registry, "replay", str(log), "-c", str(cfg), "--no-zenoh", "--no-progress") == 1
    err = capsys.readouterr().err
    assert "estimator sum" in err and "gave up" in err
    from edged.runtime import REPLAY_GIVE_UP

    # every record accounted for: the ones the failing core was given, the rest dropped
    h = [r for r in ListOutput.instances[0].records if getattr(r, "route_key", "") == "health"][-1]
    c = h.values["estimators"]["sum"]["counters"]
    assert c["errors"] == REPLAY_GIVE_UP and c["dropped.core_failure"] + c.get("steps", 0) == 199


def test_a_replay_whose_core_failed_and_lost_inputs_exits_1(registry, write_config, logs, capsys):
    cfg = write_config('[estimators.sum]\ntype = "sum"\nfail_on = 2.0\n[outputs.rec]\ntype = "list"\n')
    assert _run(registry, "replay", str(logs[0]), "-c", str(cfg), "--no-zenoh", "--no-progress") == 1
    assert "estimator sum: lost" in capsys.readouterr().err


_HUNG_DAEMON = """
import sys
import time
sys.path.insert(0, {support!r})
from core_dummies import DummyInput, ListOutput, MeanEstimator
from edged.cli import build_parser
from edged.commands import dispatch
from edged.registry import Registry

r = Registry(use_entry_points=False)
r.register("inputs", "dummy", DummyInput)
r.register("estimators", "mean", MeanEstimator)
r.register("outputs", "list", ListOutput)
sys.exit(dispatch(build_parser().parse_args(["run", "-c", {config!r}]), r))
"""


@pytest.mark.parametrize("how", ["sleeps", "computes"])
def test_sigterm_is_honoured_while_a_core_step_holds_the_event_loop(tmp_path, how):
    """A core in the loop whose step does not return (issue 30: a filter integrating
    across a month, deaf to SIGTERM for ten minutes) is interrupted half a shutdown
    timeout after the signal, reported as the core's failure, and the daemon stops with
    its outputs closed, within shutdown_timeout."""
    cfg = tmp_path / "hung.toml"
    hang = "hang_on = 0.25\nhang_for = 600.0\n" if how == "sleeps" else ""
    cfg.write_text(f"""[edged]
vessel_id = "hung"
shutdown_timeout = 2.0

[inputs.d]
type = "dummy"
lines = ["100 yaw_rate r=0.25"]

[estimators.m]
type = "mean"
worker = "loop"
{hang}
[outputs.l]
type = "list"
""")
    support = str(Path(__file__).resolve().parents[1] / "support")
    script = tmp_path / "hung.py"
    script.write_text(_HUNG_DAEMON.format(support=support, config=str(cfg)))
    if how == "computes":  # a pure-Python loop that never ends, no system call to interrupt
        script.write_text(script.read_text().replace(
            "r = Registry", "import core_dummies\n"
            "def _forever(self, rec):\n"
            "    print('event=core-hangs', file=sys.stderr, flush=True)\n"
            "    n = 0\n"
            "    while True:\n"
            "        n += 1\n"
            "core_dummies.MeanCore.step = _forever\n"
            "r = Registry", 1))
    proc = subprocess.Popen([sys.executable, str(script)], stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        for line in proc.stderr:  # the step has begun: not a sleep
            if "event=core-hangs" in line:
                break
        else:
            raise AssertionError("the core never hung")
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        rest = proc.communicate(timeout=30)[1]
        rc = proc.returncode
        took = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            proc.kill()
    assert rc == 0, rest[-2000:]
    assert took < 2.0 + 1.5, took  # shutdown_timeout, and the interpreter's own exit
    assert "event=stopped" in rest
    assert "held the event loop" in rest, rest[-2000:]
