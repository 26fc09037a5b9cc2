"""The process host (`edged.childproc`): one way to run an estimator's core or an output
in a process of its own. Each test runs both: a child killed (SIGKILL) or hung (its
watchdog kills it) is counted and restarted, and a child gives what the loop gives."""

from __future__ import annotations

import asyncio
import logging
import os
import signal
from pathlib import Path
from typing import Any

import pytest
from waiting import wait_for
from core_dummies import ListOutput

from edged.clock import ManualClock
from edged.config import parse_config
from edged.records import Estimate, HealthRecord, Measurement
from edged.childproc import ChildGone
from edged.runtime import Runtime
from edged.supervisor import RestartPolicy


async def _no_wait(delay: float) -> None:
    await asyncio.sleep(0)


def _yaw(t: float, r: float) -> Measurement:
    return Measurement("yaw_rate", "gyro", t, {"r": r})


def _runtime(registry, data: dict, *, replay: bool = False) -> Runtime:
    cfg = parse_config(data, registry)
    return Runtime(cfg, registry, ManualClock(100.0), replay=replay, restart=RestartPolicy(initial=0.01),
                   sleep=_no_wait)


class _Side:
    """One of the two kinds of child, driven the same way by the tests below."""

    def __init__(self, registry, kind: str, tmp_path: Path, **opts: Any) -> None:
        self.kind = kind
        self.path = tmp_path / f"{kind}.txt"
        if kind == "estimator":
            data = {"outputs": {"rec": {"type": "list"}},
                    "estimators": {"m": {"type": "mean", "worker": "process", "stale_after": 0.0, **opts}}}
        else:
            data = {"outputs": {"f": {"type": "file", "worker": "process", "path": str(self.path), **opts}}}
        self.rt = _runtime(registry, data, replay=True)  # (no health timer: only these inputs)
        self.host: Any = self.rt.workers[0] if kind == "estimator" else self.rt.outputs[0]
        self.published = 0

    @property
    def pid(self) -> int | None:
        return self.host.runner.pid if self.kind == "estimator" else self.host.plugin.pid

    def up(self) -> bool:
        return self.host.health.state == "running" if self.kind == "estimator" else self.host.up

    def publish(self, t: float) -> None:
        self.rt.router.publish(_yaw(t, 0.1))
        self.published += 1

    def taken(self) -> int:
        """Inputs stepped (estimator) or written to the file (output)."""
        if self.kind == "estimator":
            return self.host.health.counters.get("steps", 0)
        if not self.path.exists():
            return 0
        return sum(1 for line in self.path.read_text().splitlines() if line.split()[1:3] == ["write", "Measurement"])

    def lost(self) -> int:
        c = self.host.health.counters
        return c.get("dropped.core_failure", 0) if self.kind == "estimator" else c.get("dropped.process_died", 0)


async def _kill_and_come_back(side: _Side, sig: signal.Signals) -> tuple[int, str]:
    """Inputs before, `sig` to the child, an input that finds it dead or hung, the
    restart, inputs after; every one of them taken or counted lost."""
    rt, host = side.rt, side.host
    await rt.start()
    await wait_for(side.up)
    for i in range(3):
        side.publish(100.0 + i)
    await wait_for(lambda: side.taken() == 3)
    first = side.pid
    assert first is not None and first != os.getpid()
    os.kill(first, sig)
    side.publish(103.0)  # the one that finds the child dead, or waits on it hung
    await wait_for(lambda: host.health.restarts == 1 and side.up() and side.pid not in (None, first))
    for i in range(4, 7):
        side.publish(100.0 + i)
    await wait_for(lambda: side.taken() + side.lost() == side.published)
    error = host.health.last_error
    await rt.stop()
    with pytest.raises(ProcessLookupError):  # (hung, it did not outlive its watchdog)
        os.kill(first, 0)
    assert side.taken() >= 6 and side.taken() + side.lost() == side.published == 7
    return side.lost(), error


@pytest.mark.parametrize("kind", ["estimator", "output"])
async def test_a_killed_child_is_counted_and_started_again(registry, tmp_path, kind):
    lost, error = await _kill_and_come_back(_Side(registry, kind, tmp_path), signal.SIGKILL)
    assert "process died (exit code -9)" in error
    assert lost == 1  # the input that found it dead


@pytest.mark.parametrize("kind", ["estimator", "output"])
async def test_a_hung_child_is_killed_by_its_watchdog_and_started_again(registry, tmp_path, kind):
    """SIGSTOP: the child is there and answers nothing (a core in an endless loop, a
    disk that does not come back). Idle, nothing is due; the first call it does not
    answer within `watchdog` seconds has it killed."""
    lost, error = await _kill_and_come_back(_Side(registry, kind, tmp_path, watchdog=1.5), signal.SIGSTOP)
    assert "watchdog" in error and "1.5 s" in error
    assert lost == 1


def _streams(records: list[Any]) -> list[tuple[str, float, dict]]:
    return [(r.name, r.t, r.values) for r in records if isinstance(r, Estimate)]


@pytest.mark.parametrize("placement", ["loop", "process"])
async def test_an_estimator_gives_the_same_estimates_in_a_process_as_in_the_loop(registry, placement):
    """Decimated at 2 Hz, marked stale across a gap that health beacons fill, a chain
    consuming it: the reference is the loop's own run, record for record."""
    async def run(where: str) -> list:
        est = {"m": {"type": "mean", "worker": where, "publish_rate": 2.0, "stale_after": 1.0},
               "s": {"type": "sum", "worker": where}, "c": {"type": "chain", "upstream": "s"}}
        rt = _runtime(registry, {"outputs": {"rec": {"type": "list"}}, "estimators": est}, replay=True)
        await rt.start()
        for i in range(300):
            t = 100.0 + 0.1 * i + (5.0 if i >= 150 else 0.0)
            if i == 150:
                for b in range(1, 5):
                    rt.router.publish(HealthRecord(115.0 + b, {}))
            rt.router.publish(_yaw(t, 0.01 * (i % 7)))
            if i % 37 == 0:
                await asyncio.sleep(0)
        await rt.finish_workers(patient=True)
        await rt.stop()
        return _streams(ListOutput.instances[-1].records)

    reference = await run("loop")
    got = await run(placement)
    assert len(reference) > 300 and any(v["stale"] for _, _, v in reference)
    for name in ("m", "s", "c"):
        assert [e for e in got if e[0] == name] == [e for e in reference if e[0] == name], name


@pytest.mark.parametrize("placement", ["loop", "process"])
async def test_an_output_writes_the_same_in_a_process_as_in_the_loop(registry, tmp_path, placement):
    """The same calls, records and clock readings, in the same order: the file differs
    only in the pid that wrote each line."""
    async def run(where: str) -> list[list[str]]:
        path = tmp_path / f"{where}-{len(list(tmp_path.iterdir()))}.txt"
        rt = _runtime(registry, {"outputs": {"f": {"type": "file", "worker": where, "path": str(path)}}},
                      replay=True)
        await rt.start()
        await rt.outputs_ready()
        for k in range(20):
            for i in range(50):
                t = 100.0 + k + i * 0.01
                rt.clock.set(t)
                rt.router.publish(_yaw(t, 0.1))
            await rt.output_progress(0, timeout=60.0)
            if k % 5 == 4:
                rt.tick()
        await rt.stop()
        return [line.split()[1:] for line in path.read_text().splitlines()]

    reference = await run("loop")
    got = await run(placement)
    assert got == reference
    assert reference[0] == ["open"] and reference[-1] == ["close"] and len(reference) > 1000


async def test_calls_made_while_the_child_dies_all_end(registry):
    """The race the receiver's lock closes: a call queued while the receiver sees the
    end of the pipe fails with the others instead of waiting for ever, and every call
    after that fails at once (`ChildGone`)."""
    from edged.childproc import ChildDied, ChildGone

    rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "worker": "process"}}})
    runner = rt.workers[0].runner
    await runner.start()
    child = runner.child
    os.kill(child.pid, signal.SIGKILL)
    calls = []
    for _ in range(100_000):
        calls.append(child.submit("calls", [("step", _yaw(100.0, 0.1))]))
        if calls[-1].done():
            break
        await asyncio.sleep(0)
    results = await asyncio.wait_for(asyncio.gather(*calls, return_exceptions=True), 60.0)
    assert all(isinstance(r, ChildDied) for r in results)
    assert isinstance(results[-1], ChildGone) and "m's process is gone" in str(results[-1])
    await runner.stop()
    runner.close()


async def test_a_stop_while_a_dead_output_waits_for_its_restart_counts_the_queue_lost(registry, tmp_path):
    """The review of issue 33: an output whose process died and that waits for its
    restart when the daemon stops has nothing to take its queue. Every record is
    either written or counted lost, never counted written and gone."""
    path = tmp_path / "f.txt"
    cfg = parse_config({"outputs": {"f": {"type": "file", "worker": "process", "path": str(path)}}}, registry)
    async def backoff_for_ever(delay: float) -> None:  # the restart never comes before the stop
        if delay >= 1.0:
            await asyncio.Event().wait()
        await asyncio.sleep(0)

    rt = Runtime(cfg, registry, ManualClock(100.0), replay=True, restart=RestartPolicy(initial=30.0),
                 sleep=backoff_for_ever)
    host = rt.outputs[0]
    await rt.start()
    await wait_for(lambda: host.up)
    for i in range(3):
        rt.router.publish(_yaw(100.0 + i, 0.1))
    await wait_for(lambda: host.health.counters.get("written", 0) == 3 and not host.plugin._pending)
    os.kill(host.plugin.pid, signal.SIGKILL)
    rt.router.publish(_yaw(103.0, 0.1))  # finds it dead: the output goes to its backoff
    await wait_for(lambda: host.health.restarts == 1)
    with pytest.raises(ChildGone):  # a final write to no process is refused aloud
        host.plugin.write([_yaw(200.0, 0.1)])
    for i in range(4, 9):
        rt.router.publish(_yaw(100.0 + i, 0.1))
    await rt.stop()
    c = host.health.counters
    lost = sum(v for k, v in c.items() if k.startswith("dropped.")) + c.get("overflow", 0)
    written = sum(1 for line in path.read_text().splitlines() if line.split()[1:3] == ["write", "Measurement"])
    assert written == 3
    assert c.get("written", 0) - c.get("dropped.process_died", 0) == written, c
    assert written + lost == 9, c


def test_a_childs_logged_exception_reaches_the_parent_with_its_traceback():
    """A core or plugin in a process that logs an exception: the parent's log shows
    where it came from, not the message alone."""
    from edged.childmain import _Collect

    collect = _Collect()
    log = logging.getLogger("edged.test.child")
    log.addHandler(collect)
    try:
        try:
            {}["missing"]
        except KeyError:
            log.exception("step failed")
    finally:
        log.removeHandler(collect)
    ((name, level, text),) = collect.take()
    assert (name, level) == ("edged.test.child", logging.ERROR)
    assert text.startswith("step failed\nTraceback") and "KeyError: 'missing'" in text


async def test_a_plugin_in_a_process_resolves_paths_from_the_configuration_files_folder(registry, tmp_path):
    """A zenoh output's TLS files are named relative to the configuration file: in its
    process the plugin must see the same folder as in the loop, not the working one."""
    etc = tmp_path / "etc" / "edged"
    etc.mkdir(parents=True)
    data = {"outputs": {"f": {"type": "file", "worker": "process", "path": str(tmp_path / "f.txt")}}}
    cfg = parse_config(data, registry, config_dir=etc)
    cfg.path = etc / "edged.toml"  # (as load_config sets it)
    rt = Runtime(cfg, registry, ManualClock(100.0), replay=True, restart=RestartPolicy(initial=0.01), sleep=_no_wait)
    host = rt.outputs[0]
    await rt.start()
    try:
        await wait_for(lambda: host.up and "config_dir" in host.health.info)
        assert host.health.info["pid"] != os.getpid()
        assert host.health.info["config_dir"] == str(etc)
    finally:
        await rt.stop()
