"""Runtime: supervision with backoff, isolation, graceful shutdown, health."""

from __future__ import annotations

import asyncio
import os
import signal

import pytest
from core_dummies import ListOutput, SumEstimator

from edged.clock import ManualClock
from edged.runcmd import run_daemon
from edged.config import parse_config
from edged.health import ComponentHealth
from edged.records import HealthRecord, Measurement
from edged.runtime import Runtime
from edged.backoff import Backoff
from edged.supervisor import RestartPolicy, supervise


class RecordingSleep:
    """Backoff sleeps that return at once but remember what was asked."""

    def __init__(self) -> None:
        self.delays: list[float] = []

    async def __call__(self, d: float) -> None:
        self.delays.append(d)
        await asyncio.sleep(0)


def test_backoff_delays_are_exponential_capped_and_reset():
    b = Backoff(initial=1.0, maximum=10.0, factor=2.0)
    assert [b.next_delay() for _ in range(6)] == [1.0, 2.0, 4.0, 8.0, 10.0, 10.0]
    b.reset()
    assert b.next_delay() == 1.0


def test_backoff_rejects_nonsense():
    with pytest.raises(ValueError):
        Backoff(initial=0.0)
    with pytest.raises(ValueError):
        Backoff(initial=5.0, maximum=1.0)


async def test_supervise_restarts_with_backoff_then_succeeds():
    clock = ManualClock()
    h = ComponentHealth("x", "input", "t", clock)
    sleep = RecordingSleep()
    calls = 0

    async def flaky() -> None:
        nonlocal calls
        calls += 1
        if calls <= 3:
            raise ConnectionError(f"refused {calls}")

    await supervise(flaky, h, clock, sleep=sleep)
    assert calls == 4
    assert sleep.delays == [1.0, 2.0, 4.0]
    assert h.restarts == 3 and h.counters["errors"] == 3
    assert h.last_error == "ConnectionError: refused 3"
    assert h.state == "finished"


async def test_supervise_resets_backoff_after_a_stable_run():
    clock = ManualClock()
    h = ComponentHealth("x", "input", "t", clock)
    sleep = RecordingSleep()
    calls = 0

    async def run() -> None:
        nonlocal calls
        calls += 1
        if calls == 3:
            clock.step(120.0)  # this run lasted two minutes before failing
        if calls <= 4:
            raise RuntimeError("x")

    await supervise(run, h, clock, sleep=sleep, policy=RestartPolicy(stable_after=60.0))
    assert sleep.delays == [1.0, 2.0, 1.0, 2.0]


def _runtime(registry, data: dict, *, replay: bool = False, sleep=None) -> Runtime:
    cfg = parse_config(data, registry)
    kw = {"sleep": sleep} if sleep else {}
    return Runtime(cfg, registry, ManualClock(100.0), replay=replay, **kw)


async def test_failing_input_restarts_while_the_others_keep_running(registry):
    sleep = RecordingSleep()
    rt = _runtime(
        registry,
        {
            "inputs": {
                "bad": {"type": "dummy", "fail_times": 2, "lines": ["1.0 yaw_rate r=0.5"]},
            },
            "estimators": {"sum": {"type": "sum"}},
            "outputs": {"rec": {"type": "list"}},
        },
        sleep=sleep,
    )
    out = ListOutput.instances[0]
    await rt.start()
    await asyncio.wait_for(out.got_first.wait(), 2.0)
    # drain until the estimate made from the third run's line has arrived
    for _ in range(100):
        if any(getattr(r, "name", None) == "sum" for r in out.records):
            break
        await asyncio.sleep(0)
    h = rt.health.components["input:bad"]
    assert h.restarts == 2 and h.last_error == "RuntimeError: boom 2"
    assert sleep.delays[:2] == [1.0, 2.0]
    assert any(getattr(r, "name", None) == "sum" for r in out.records)
    await rt.stop()
    assert out.events[0] == "open" and out.events[-1] == "close"


async def test_failing_worker_is_restarted_with_a_fresh_core(registry):
    sleep = RecordingSleep()
    rt = _runtime(
        registry,
        {"estimators": {"sum": {"type": "sum", "fail_on": 13.0}}, "outputs": {"rec": {"type": "list"}}},
        sleep=sleep,
    )
    await rt.start()
    for i, r in enumerate([1.0, 13.0, 2.0]):
        rt.router.publish(Measurement("yaw_rate", "g", float(i), {"r": r}))
        for _ in range(20):
            await asyncio.sleep(0)
    await rt.stop()
    w = rt.health.components["estimator:sum"]
    assert w.restarts == 1 and "bad value" in w.last_error
    assert len(SumEstimator.cores) == 2
    assert SumEstimator.cores[1].times == [2.0]


async def test_failing_output_is_closed_and_reopened(registry):
    sleep = RecordingSleep()
    rt = _runtime(registry, {"outputs": {"rec": {"type": "list", "fail_writes": 1}}}, sleep=sleep)
    out = ListOutput.instances[0]
    await rt.start()
    rt.router.publish(Measurement("yaw_rate", "g", 1.0, {"r": 1.0}))
    rt.router.publish(Measurement("yaw_rate", "g", 2.0, {"r": 1.0}))
    await asyncio.wait_for(out.got_first.wait(), 2.0)
    await rt.stop()
    assert out.events[:4] == ["open", "write-failed", "close", "open"]
    assert rt.health.components["output:rec"].last_error.startswith("OSError")
    assert sleep.delays == [1.0]


async def test_sigterm_stops_gracefully_and_closes_outputs(registry):
    rt = _runtime(
        registry,
        {
            "inputs": {"g": {"type": "dummy", "lines": ["1.0 yaw_rate r=0.5", "2.0 yaw_rate r=0.25"]}},
            "estimators": {"sum": {"type": "sum"}},
            "outputs": {"rec": {"type": "list"}},
        },
    )
    out = ListOutput.instances[0]

    async def terminate_when_data_flows() -> None:
        await out.got_first.wait()
        os.kill(os.getpid(), signal.SIGTERM)

    killer = asyncio.ensure_future(terminate_when_data_flows())
    assert await asyncio.wait_for(run_daemon(rt), 5.0) == 0
    await killer
    assert out.events[-2:] == ["flush", "close"]
    totals = [r.values["total"] for r in out.records if getattr(r, "name", None) == "sum"]
    assert totals == [0.5, 0.75]  # everything queued before SIGTERM was delivered
    assert all(h.state == "stopped" for h in rt.health.components.values() if h.role != "core")


async def test_sighup_rotates_outputs(registry):
    rt = _runtime(registry, {"outputs": {"rec": {"type": "list"}}})
    out = ListOutput.instances[0]
    stop = asyncio.Event()

    async def hup_then_stop() -> None:
        while "open" not in out.events:
            await asyncio.sleep(0)
        os.kill(os.getpid(), signal.SIGHUP)
        while "rotate" not in out.events:
            await asyncio.sleep(0)
        stop.set()

    helper = asyncio.ensure_future(hup_then_stop())
    await asyncio.wait_for(run_daemon(rt, stop), 5.0)
    await helper
    assert "rotate" in out.events


async def test_health_snapshot_reaches_outputs_with_counters_and_rates(registry):
    sleep = RecordingSleep()
    rt = _runtime(registry, {"outputs": {"rec": {"type": "list"}}, "estimators": {"s": {"type": "sum"}}}, sleep=sleep)
    await rt.start()
    clock = rt.clock
    rt.tick()
    for i in range(4):
        rt.router.publish(Measurement("yaw_rate", "g", 100.0 + i, {"r": 1.0}))
    for _ in range(10):
        await asyncio.sleep(0)
    clock.step(2.0)
    rt.tick()
    await rt.stop()
    out = ListOutput.instances[0]
    snaps = [r for r in out.records if isinstance(r, HealthRecord)]
    assert len(snaps) >= 2
    s = snaps[1].values["estimators"]["s"]
    assert s["state"] == "running" and s["counters"]["steps"] == 4 and s["rates"]["steps"] == 2.0
    assert snaps[1].values["vessel_id"] == "vessel"
    assert snaps[1].values["cores"]["router"]["info"]["published"] >= 5


async def test_reorder_window_restores_time_order(registry):
    rt = _runtime(registry, {"estimators": {"s": {"type": "sum", "reorder_window": 1.0}}}, replay=True)
    await rt.start()
    for t in (1.0, 3.0, 2.5, 2.2, 0.5, 4.0, 5.0):
        rt.router.publish(Measurement("yaw_rate", "g", t, {"r": 1.0}))
    await rt.stop()  # finishing a worker releases what its window still holds
    assert SumEstimator.cores[0].times == [1.0, 2.2, 2.5, 3.0, 4.0, 5.0]
    assert rt.workers[0].health.counters["late"] == 1


async def test_stop_is_bounded_when_a_plugin_ignores_cancellation(registry):
    from core_dummies import DummyInput

    class Stubborn(DummyInput):
        async def run(self) -> None:
            try:
                await asyncio.Event().wait()
            except asyncio.CancelledError:
                pass  # the bug this guards against: a swallowed cancellation
            await asyncio.Event().wait()  # the event loop's teardown ends this one

    registry.register("inputs", "stubborn", Stubborn)
    rt = _runtime(
        registry,
        {"edged": {"shutdown_timeout": 0.05}, "inputs": {"s": {"type": "stubborn"}}, "outputs": {"rec": {"type": "list"}}},
    )
    await rt.start()
    await asyncio.wait_for(rt.stop(), 5.0)
    assert ListOutput.instances[0].events[-1] == "close"


def test_health_marks_each_component_and_the_whole_ok_or_not():
    from edged.health import HealthRegistry

    reg = HealthRegistry(ManualClock())
    reg.component("gnss", "input").set_state("connected")
    reg.component("rec", "output").set_state("recording")
    snap = reg.snapshot()
    assert snap["ok"] is True and snap["inputs"]["gnss"]["ok"] is True
    reg.component("rec", "output").set_state("disk_full")
    snap = reg.snapshot()
    assert snap["ok"] is False and snap["outputs"]["rec"]["ok"] is False


async def test_a_stop_that_loses_records_is_said_and_exits_1(registry, caplog):
    """A daemon's stop must not look clean when it lost records: the output that could
    not take its last batch counts them (`dropped.final_write`), the log names it, and
    the exit code is 1 (systemd then shows the stop as failed)."""
    rt = _runtime(registry, {"outputs": {"rec": {"type": "list"}}})
    host = rt.outputs[0]
    out = ListOutput.instances[0]
    stop = asyncio.Event()
    drain = host.drain_and_close

    def full_disk(batch):
        raise OSError(28, "No space left on device")

    async def the_disk_fills_as_the_daemon_stops() -> None:
        for i in range(7):  # queued for the final drain
            rt.router.publish(Measurement("yaw_rate", "g", 1.0 + i, {"r": 0.1}))
        out.write = full_disk
        await drain()

    host.drain_and_close = the_disk_fills_as_the_daemon_stops

    async def then_stop() -> None:
        while "open" not in out.events:
            await asyncio.sleep(0)
        stop.set()

    helper = asyncio.ensure_future(then_stop())
    assert await asyncio.wait_for(run_daemon(rt, stop), 5.0) == 1
    await helper
    assert host.health.counters["dropped.final_write"] == 7
    assert "event=stopped-with-loss output=rec lost=7" in caplog.text


async def test_a_stop_that_loses_nothing_exits_0_after_losses_earlier_in_the_run(registry):
    rt = _runtime(registry, {"outputs": {"rec": {"type": "list"}}})
    out = ListOutput.instances[0]
    stop = asyncio.Event()

    async def then_stop() -> None:
        while "open" not in out.events:
            await asyncio.sleep(0)
        rt.outputs[0].health.count("dropped.overflow_earlier", 3)  # counted, said in health long ago
        stop.set()

    helper = asyncio.ensure_future(then_stop())
    assert await asyncio.wait_for(run_daemon(rt, stop), 5.0) == 0
    await helper
