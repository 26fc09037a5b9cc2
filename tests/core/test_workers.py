"""Estimator workers: data-determined input order, placement, ticks, stale, health, names."""

from __future__ import annotations

import asyncio
import os
import signal
from typing import Any

import pytest
from waiting import wait_for
from core_dummies import ListOutput

from edged.clock import ManualClock
from edged.config import ConfigError, parse_config
from edged.innovation import InnovationMonitor, chi2_band
from edged.records import Estimate, HealthRecord, Measurement
from edged.runtime import Runtime

SAFETY = 60.0  # seconds: only a broken worker ever waits this long


def _runtime(registry, data: dict, *, replay: bool = False) -> Runtime:
    cfg = parse_config({"outputs": {"rec": {"type": "list"}}, **data}, registry)
    return Runtime(cfg, registry, ManualClock(100.0), replay=replay)


async def settle(rt: Runtime, timeout: float = SAFETY) -> None:
    """Wait until every worker has stepped everything the router has published."""
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while any(w.watermark() < rt.router.seq for w in rt.workers):
        if loop.time() > end:
            raise AssertionError("workers did not catch up")
        await asyncio.sleep(0.001)


def streams(records: list[Any]) -> dict[str, list[tuple[float, dict]]]:
    out: dict[str, list] = {}
    for r in records:
        if isinstance(r, Estimate):
            out.setdefault(r.name, []).append((r.t, r.values))
    return out


def yaw(t: float, r: float, source: str = "gyro") -> Measurement:
    return Measurement("yaw_rate", source, t, {"r": r})


CHAIN = {"sum": {"type": "sum"}, "chain": {"type": "chain", "upstream": "sum"}}


@pytest.mark.parametrize("placement", ["loop", "process"])
@pytest.mark.parametrize("settle_every", [1, 7, 1000])
async def test_chain_sees_a_measurement_then_its_upstream_estimate_whatever_the_scheduling(
    registry, placement, settle_every
):
    est = {"sum": {"type": "sum", "worker": placement}, "chain": {"type": "chain", "upstream": "sum"}}
    rt = _runtime(registry, {"estimators": est})
    await rt.start()
    for i in range(40):
        rt.router.publish(yaw(100.0 + i * 0.1, float(i % 5)))
        if (i + 1) % settle_every == 0:
            await settle(rt)
    await settle(rt)
    await rt.stop()
    got = streams(ListOutput.instances[0].records)
    assert [v["trace"] for _, v in got["chain"]][-1] == "ye" * 8
    # the reference: every record stepped at once in the event loop
    assert len(got["chain"]) == 80 and len(got["sum"]) == 40
    reference = _reference_chain(registry)
    assert got["chain"] == reference


def _reference_chain(registry, n: int = 40) -> list:
    from core_dummies import ChainConfig, ChainCore, SumConfig, SumCore

    s, c = SumCore(SumConfig(type="sum")), ChainCore(ChainConfig(type="chain", upstream="sum"))
    out = []
    for i in range(n):
        m = yaw(100.0 + i * 0.1, float(i % 5))
        for rec in [m, *s.step(m)]:
            for e in c.step(rec):
                out.append((e.t, {**e.values, "stale": False, "age": 0.0}))
    return out


@pytest.mark.parametrize("placement", ["loop", "process"])
async def test_a_burst_larger_than_a_batch_keeps_the_order(registry, placement):
    """More inputs than one batch takes, published before the workers even run: the
    rest still queued must hold the watermark back (nothing counted late)."""
    n = 3000
    est = {"sum": {"type": "sum", "worker": placement}, "chain": {"type": "chain", "upstream": "sum"}}
    rt = _runtime(registry, {"estimators": est})
    for i in range(n):
        rt.router.publish(yaw(100.0 + i * 0.1, float(i % 5)))
    await rt.start()
    await settle(rt)
    await rt.stop()
    assert all(w.health.counters.get("late", 0) == 0 for w in rt.workers)
    assert streams(ListOutput.instances[0].records)["chain"] == _reference_chain(registry, n)


async def test_estimates_are_published_under_the_instance_name_with_the_plugin_kind(registry):
    rt = _runtime(registry, {"estimators": {"stw": {"type": "mean"}, "stw_paper": {"type": "mean"}}})
    await rt.start()
    rt.router.publish(yaw(100.0, 0.1))
    await settle(rt)
    await rt.stop()
    ests = [r for r in ListOutput.instances[0].records if isinstance(r, Estimate)]
    assert sorted((e.name, e.route_key, e.kind, e.source) for e in ests) == [
        ("stw", "est/stw", "stw", "stw"),
        ("stw_paper", "est/stw_paper", "stw", "stw_paper"),
    ]


def test_a_consumed_estimate_that_no_instance_makes_is_a_configuration_error(registry):
    with pytest.raises(ConfigError) as exc:
        _runtime(registry, {"estimators": {"chain": {"type": "chain", "upstream": "stw"}}})
    assert "estimators.chain: consumes est/stw, but no estimator instance is named 'stw'" in str(exc.value)


def test_estimators_that_consume_each_other_are_a_configuration_error(registry):
    est = {"a": {"type": "chain", "upstream": "b"}, "b": {"type": "chain", "upstream": "a"}}
    with pytest.raises(ConfigError) as exc:
        _runtime(registry, {"estimators": est})
    assert "cycle" in str(exc.value)


async def test_workers_are_ordered_upstream_first_whatever_the_configuration_order(registry):
    rt = _runtime(registry, {"estimators": {"chain": {"type": "chain", "upstream": "sum"}, "sum": {"type": "sum"}}})
    assert [w.name for w in rt.workers] == ["sum", "chain"]
    await rt.start()
    rt.router.publish(yaw(100.0, 1.0))
    await settle(rt)
    await rt.stop()
    assert [v["trace"] for _, v in streams(ListOutput.instances[0].records)["chain"]] == ["y", "ye"]


async def test_preferred_only_is_per_estimator(registry):
    data = {
        "router": {"priority": {"yaw_rate": ["a", "b"]}},
        "estimators": {"fused": {"type": "mean", "preferred_only": False}, "one": {"type": "mean"}},
    }
    rt = _runtime(registry, data)
    await rt.start()
    for i in range(3):
        rt.router.publish(yaw(100.0 + i, 0.1, "a"))
        rt.router.publish(yaw(100.0 + i, 0.3, "b"))
    await settle(rt)
    await rt.stop()
    got = streams(ListOutput.instances[0].records)
    assert got["fused"][-1][1]["n"] == 6  # both receivers
    assert got["one"][-1][1]["n"] == 3  # the priority's winner only


async def test_publish_rate_decimates_on_data_time_the_same_at_any_batching(registry):
    async def run(settle_every: int) -> list:
        rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "publish_rate": 1.0}}})
        await rt.start()
        for i in range(50):  # 10 Hz for 5 s of data
            rt.router.publish(yaw(100.05 + i * 0.1, 0.01 * i))
            if (i + 1) % settle_every == 0:
                await settle(rt)
        await settle(rt)
        await rt.stop()
        return streams(ListOutput.instances[-1].records)["m"]

    one_by_one = await run(1)
    assert one_by_one == await run(13) == await run(1000)
    # one per grid second 101..104, each the newest estimate before that tick, and the
    # newest of all when the worker finishes (nothing held back at the end)
    assert [round(t, 2) for t, _ in one_by_one] == [100.95, 101.95, 102.95, 103.95, 104.95]
    assert [v["n"] for _, v in one_by_one] == [10, 20, 30, 40, 50]


async def test_a_core_with_tick_publishes_on_the_grid(registry):
    rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "publish_rate": 2.0, "tick_only": True}}})
    await rt.start()
    for i in range(30):
        rt.router.publish(yaw(100.0 + i * 0.1, 0.2))
    await settle(rt)
    await rt.stop()
    got = streams(ListOutput.instances[0].records)["m"]
    assert [t for t, _ in got] == [100.5, 101.0, 101.5, 102.0, 102.5]


async def test_a_process_worker_makes_no_core_in_the_parent(registry):
    """What a process worker's core consumes and whether it ticks are read from its
    class and configuration (`EstimatorPlugin.inputs()`, `ticks()`): its only core is
    the one made in its own process."""
    from core_dummies import SumEstimator

    rt = _runtime(registry, {"estimators": {"s": {"type": "sum", "worker": "process"}}})
    assert rt.workers[0].inputs == {"yaw_rate"}
    await rt.start()
    rt.router.publish(yaw(100.0, 1.5))
    await settle(rt)
    await rt.stop()
    assert SumEstimator.cores == []  # (those made here; the child's are its own)
    assert [v["total"] for _, v in streams(ListOutput.instances[0].records)["s"]] == [1.5]


async def test_an_estimate_goes_stale_when_its_inputs_stop_and_recovers(registry):
    rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "stale_after": 2.0}}})
    await rt.start()
    for i in range(3):
        rt.router.publish(yaw(100.0 + i, 0.1))
    # no input any more; health snapshots move data time on (1 Hz beacons)
    for t in (103.0, 104.0, 105.0, 106.0):
        rt.clock.set(t)
        rt.tick(flush=False)
    await settle(rt)
    state_while_stale = rt.workers[0].health.state
    rt.router.publish(yaw(106.5, 0.1))
    await settle(rt)
    await rt.stop()
    got = streams(ListOutput.instances[0].records)["m"]
    flags = [(t, v["stale"], v["age"]) for t, v in got]
    assert flags == [
        (100.0, False, 0.0), (101.0, False, 0.0), (102.0, False, 0.0),
        (105.0, True, 3.0), (106.0, True, 4.0),  # ticks with more than 2 s since the last input
        (106.5, False, 0.0),
    ]
    assert got[3][1]["mean"] == got[2][1]["mean"]  # the last values, marked
    assert state_while_stale == "stale"
    assert rt.workers[0].health.counters["stale_periods"] == 1


async def test_stale_marks_are_the_same_in_replay_and_live(registry):
    async def run(replay: bool) -> list:
        rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "stale_after": 1.5}}}, replay=replay)
        await rt.start()
        rt.router.publish(yaw(100.0, 0.1))
        if replay:  # replay: health once per second of data, as the replay driver does
            for t in (101.0, 102.0, 103.0):
                rt.router.publish(HealthRecord(t, {}))
        else:  # live: the health timer, at moments of its own
            for t in (100.7, 101.9, 102.2, 103.0):
                rt.clock.set(t)
                rt.tick(flush=False)
        rt.router.publish(yaw(103.5, 0.2))
        await settle(rt)
        await rt.stop()
        return streams(ListOutput.instances[-1].records)["m"]

    assert await run(True) == await run(False)


async def test_a_process_worker_that_is_killed_comes_back(registry):
    rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "worker": "process"}}})
    rt.restart = type(rt.restart)(initial=0.01, maximum=0.01)
    await rt.start()
    w = rt.workers[0]
    rt.router.publish(yaw(100.0, 0.1))
    await settle(rt)
    pid = w.runner.pid
    assert pid is not None and pid != os.getpid()
    os.kill(pid, signal.SIGKILL)
    rt.router.publish(yaw(101.0, 0.2))  # the batch that finds the process dead
    await wait_for(lambda: w.health.restarts == 1 and w.runner.pid not in (None, pid))
    rt.router.publish(yaw(102.0, 0.3))
    await settle(rt)
    await rt.stop()
    # the same report whether the send or the receive found the pipe broken first
    assert "process died (exit code -9)" in w.health.last_error
    assert w.health.counters["dropped.core_failure"] == 1  # 101.0: the batch the dead process lost
    got = streams(ListOutput.instances[0].records)["m"]
    # a fresh core after the restart: its count starts again
    assert [(t, v["n"]) for t, v in got][0] == (100.0, 1) and got[-1][1]["n"] >= 1 and got[-1][0] == 102.0
    assert w.runner.process is None  # stopped with the runtime


async def test_a_hung_process_worker_is_killed_by_its_watchdog_and_restarted(registry):
    est = {"m": {"type": "mean", "worker": "process", "watchdog": 0.5, "hang_on": 0.25, "hang_for": 30.0}}
    rt = _runtime(registry, {"estimators": est})
    rt.restart = type(rt.restart)(initial=0.01, maximum=0.01)
    await rt.start()
    w = rt.workers[0]
    rt.router.publish(yaw(100.0, 0.25))
    await wait_for(lambda: w.health.restarts == 1)
    rt.router.publish(yaw(101.0, 0.1))
    await settle(rt)
    await rt.stop()
    assert "watchdog" in w.health.last_error
    assert streams(ListOutput.instances[0].records)["m"][-1][0] == 101.0


@pytest.mark.parametrize("placement", ["loop", "process"])
async def test_estimator_health_carries_the_cores_innovation_statistics(registry, placement):
    rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "worker": placement}}})
    await rt.start()
    for i, r in enumerate([0.1, 0.2, 5.0, 0.5, 0.3]):
        rt.router.publish(yaw(100.0 + i, r))
    await settle(rt)
    snap = rt.health_snapshot()
    await rt.stop()
    info = snap["estimators"]["m"]["info"]
    assert info["placement"] == placement
    f = info["filter"]
    yr = f["innovation"]["yaw_rate"]
    assert yr["updates"] == 4 and yr["gated"] == 1 and yr["window"] == 4
    assert 0.0 < yr["nis_mean"] < 1.0 and 0.0 <= yr["in_band_95"] <= 1.0
    assert f["resets"] == 1 and f["last_reset"] == "r was 0.5" and f["last_reset_t"] == 103.0


@pytest.mark.parametrize("placement", ["loop", "process"])
async def test_a_core_that_names_a_problem_makes_its_worker_not_ok_until_it_is_gone(registry, placement):
    rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "worker": placement}}})
    await rt.start()
    rt.router.publish(yaw(100.0, 0.1))
    await settle(rt)
    fine = rt.health_snapshot()
    rt.router.publish(yaw(101.0, -0.2))
    await settle(rt)
    wrong = rt.health_snapshot()
    rt.router.publish(yaw(102.0, 0.3))
    await settle(rt)
    again = rt.health_snapshot()
    await rt.stop()
    assert fine["estimators"]["m"]["ok"] is True and fine["estimators"]["m"]["problems"] == []
    m = wrong["estimators"]["m"]
    assert m["state"] == "running" and m["ok"] is False and wrong["ok"] is False
    assert m["problems"] == ["yaw_rate/gyro: r -0.2 is negative"]
    assert again["estimators"]["m"]["ok"] is True and again["estimators"]["m"]["problems"] == []


async def test_inputs_are_polled_for_status_too(registry):
    from core_dummies import DummyInput

    class Talkative(DummyInput):
        def status(self) -> dict[str, Any]:
            return {"said": "hello"}

    registry.register("inputs", "talk", Talkative)
    rt = _runtime(registry, {"inputs": {"t": {"type": "talk"}}})
    assert rt.health_snapshot()["inputs"]["t"]["info"]["said"] == "hello"


def test_chi2_band_and_monitor_agree_with_a_consistent_filter():
    import numpy as np

    lo, hi = chi2_band(1)
    assert lo == pytest.approx(0.000982, rel=1e-2) and hi == pytest.approx(5.024, rel=1e-3)
    from scipy.stats import chi2  # the reference (scipy comes with filterpy)

    for dof in (1, 2, 3, 6, 12, 40):
        assert chi2_band(dof) == pytest.approx((chi2.ppf(0.025, dof), chi2.ppf(0.975, dof)), rel=1e-9)
    rng = np.random.default_rng(7)
    mon = InnovationMonitor(window=4000)
    for nu in rng.normal(size=(4000, 2)):
        mon.update("position", float(nu @ nu), 2)
    s = mon.snapshot()["innovation"]["position"]
    assert s["nis_mean"] == pytest.approx(2.0, abs=0.1)
    assert s["in_band_95"] == pytest.approx(0.95, abs=0.015)
    with pytest.raises(ValueError):
        InnovationMonitor(window=0)


async def test_tick_times_are_exact_grid_points_however_long_the_run(registry):
    """k / rate, never a running sum: six hours of 10 Hz ticks at today's epoch land
    on the grid, so runs that start at different moments share every tick (a sum of
    0.1 s steps drifts by tens of ms a day)."""
    t0 = 1_732_350_000.03
    est = {"m": {"type": "mean", "publish_rate": 10.0, "tick_only": True, "stale_after": 0.0}}
    rt = _runtime(registry, {"estimators": est})
    await rt.start()
    for i in range(0, 6 * 3600 + 1, 60):  # one input a minute: 600 ticks between
        rt.router.publish(yaw(t0 + i, 0.1))
    await settle(rt)
    await rt.stop()
    ticks = [t for t, _ in streams(ListOutput.instances[0].records)["m"]]
    assert len(ticks) == 6 * 3600 * 10
    k0 = round(ticks[0] * 10)
    assert all(t == (k0 + i) / 10 for i, t in enumerate(ticks))


async def test_a_gap_longer_than_the_catch_up_bound_skips_ticks_and_counts_them(registry):
    rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "publish_rate": 1.0, "stale_after": 0.0}}})
    await rt.start()
    rt.router.publish(yaw(100.5, 0.1))
    rt.router.publish(yaw(100.5 + 5000.0, 0.2))  # 5000 ticks in the gap: more than 1000
    await settle(rt)
    await rt.stop()
    assert rt.workers[0].health.counters["ticks_skipped"] == 4999


async def test_a_failing_core_counts_the_input_it_failed_on_and_what_followed(registry):
    rt = _runtime(registry, {"estimators": {"s": {"type": "sum", "fail_on": 13.0, "stale_after": 0.0}}})
    rt.restart = type(rt.restart)(initial=0.01, maximum=0.01)
    for i, r in enumerate((1.0, 2.0, 13.0, 4.0, 5.0, 6.0)):  # one batch: the failure takes 13, 4, 5, 6
        rt.router.publish(yaw(100.0 + i, r))
    await rt.start()
    await wait_for(lambda: rt.workers[0].health.restarts == 1)
    await rt.stop()
    h = rt.workers[0].health
    assert h.counters["steps"] == 2 and h.counters["dropped.core_failure"] == 4


async def test_a_process_core_failing_after_the_first_message_of_a_batch_loses_only_what_followed(registry):
    """A batch to a process goes as messages of CHUNK_PROCESS calls, the next sent before
    the last one's answer: a failure in the second keeps the first's results and the
    calls before it in the second, and counts the rest."""
    from edged.workerproc import CHUNK_PROCESS

    n, bad = 2 * CHUNK_PROCESS + 88, CHUNK_PROCESS + 44
    rt = _runtime(registry, {"estimators": {"s": {"type": "sum", "fail_on": 13.0, "stale_after": 0.0,
                                                  "worker": "process"}}})
    rt.restart = type(rt.restart)(initial=0.01, maximum=0.01)
    for i in range(n):
        rt.router.publish(yaw(100.0 + i, 13.0 if i == bad else 1.0))
    await rt.start()
    await wait_for(lambda: rt.workers[0].health.restarts == 1)
    await rt.stop()
    h = rt.workers[0].health
    assert h.counters["steps"] == bad and h.counters["dropped.core_failure"] == n - bad


async def test_a_batch_that_waited_its_turn_behind_a_killed_process_fails_cleanly(registry):
    """After a failure the runner's process is killed; a batch already queued behind
    the failing one then reaches no pipe: it fails as a core failure (counted lost by
    the host), not with an AttributeError on a closed connection."""
    from edged.workerproc import CoreFailed

    rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "worker": "process"}}})
    runner = rt.workers[0].runner  # never started, or killed: no pipe
    with pytest.raises(CoreFailed, match="process is gone"):
        await runner.call([("tick", 1.0)])
    runner.close()


async def test_stop_does_not_wait_on_an_upstream_worker_in_backoff(registry):
    est = {"sum": {"type": "sum", "fail_on": 13.0}, "chain": {"type": "chain", "upstream": "sum"}}
    rt = _runtime(registry, {"edged": {"shutdown_timeout": 30.0}, "estimators": est})
    rt.restart = type(rt.restart)(initial=3600.0, maximum=3600.0)  # it will not come back
    await rt.start()
    rt.router.publish(yaw(100.0, 13.0))
    await wait_for(lambda: rt.workers[0].health.state == "backoff")
    rt.router.publish(yaw(101.0, 1.0))
    loop = asyncio.get_running_loop()
    t0 = loop.time()
    await rt.stop()
    assert loop.time() - t0 < 10.0  # not the 30 s shutdown timeout
    chain = rt.workers[1].health
    assert chain.counters["steps"] == 2 and "dropped.shutdown" not in chain.counters
    assert rt.workers[0].health.counters["dropped.shutdown"] == 1  # the sum never saw 101.0


async def test_finishing_twice_is_harmless_and_wakes_are_not_counted_as_drops(registry):
    rt = _runtime(registry, {"estimators": {"m": {"type": "mean", "worker": "process"}}})
    await rt.start()
    rt.router.publish(yaw(100.0, 0.1))
    await settle(rt)
    await rt.finish_workers()
    await rt.stop()  # finishes again
    h = rt.workers[0].health
    assert "errors" not in h.counters and "dropped.shutdown" not in h.counters


@pytest.mark.parametrize(
    "tables, says",
    [
        ('[estimators.chain]\ntype = "chain"\nupstream = "nope"\n', "no estimator instance is named 'nope'"),
        (
            '[estimators.a]\ntype = "chain"\nupstream = "b"\n[estimators.b]\ntype = "chain"\nupstream = "a"\n',
            "cycle",
        ),
    ],
)
def test_check_config_refuses_what_run_refuses_about_estimator_chains(registry, tmp_path, capsys, tables, says):
    from edged.cli import build_parser
    from edged.commands import dispatch

    cfg = tmp_path / "edged.toml"
    cfg.write_text(tables)
    for argv in (["check-config", str(cfg)], ["run", "-c", str(cfg)]):
        assert dispatch(build_parser().parse_args(argv), registry) == 2
        assert says in capsys.readouterr().err


@pytest.mark.parametrize("placement", ["loop", "process"])
async def test_a_replay_waiting_for_room_wakes_when_the_full_worker_takes_a_batch(registry, placement):
    """The replay's back-pressure awaits the worker's next batch (no poll of the loop);
    with nothing over the limit it returns at once, and a worker that takes nothing
    (not running) lets it go after the timeout."""
    rt = _runtime(registry, {"estimators": {"sum": {"type": "sum", "worker": placement, "queue_size": 64}}})
    for i in range(60):
        rt.router.publish(yaw(100.0 + i * 0.1, 1.0))
    w = rt.workers[0]
    assert w.backlog == 60
    loop = asyncio.get_running_loop()
    t0 = loop.time()
    await rt.worker_progress(100, timeout=SAFETY)  # nothing over the limit: no wait
    await rt.worker_progress(32, timeout=0.05)  # not started: nothing taken, the timeout
    assert w.backlog == 60 and loop.time() - t0 < SAFETY / 2
    await rt.start()
    t1 = loop.time()
    await rt.worker_progress(32, timeout=SAFETY)
    assert w.backlog < 60 and loop.time() - t1 < SAFETY / 2  # woken by the batch it took
    await settle(rt)
    await rt.stop()
    assert len(streams(ListOutput.instances[0].records)["sum"]) == 60


@pytest.mark.parametrize("placement, n, timeout", [("loop", 20, 0.1), ("loop", 60, 0.1)])
async def test_a_replay_end_waits_for_a_slow_core_that_makes_progress(registry, placement, n, timeout):
    """Issue 32: a replay's final drain was bounded by `shutdown_timeout`; on a loaded
    machine a real log lost 128 inputs at its end. Here each step takes 10 ms: the
    queue takes 2-6 x `shutdown_timeout`, and every record is stepped (a core that
    steps nothing is still given up on: the daemon's own tests of stop-timeout)."""
    cfg = parse_config({"edged": {"shutdown_timeout": timeout}, "outputs": {"rec": {"type": "list"}},
                        "estimators": {"m": {"type": "mean", "worker": placement, "step_delay": 0.01}}}, registry)
    rt = Runtime(cfg, registry, ManualClock(100.0), replay=True)
    await rt.start()
    for i in range(n):
        rt.router.publish(yaw(100.0 + i * 0.1, 0.1))
    await rt.finish_workers(patient=True)
    await rt.stop()
    w = rt.workers[0]
    assert w.health.counters.get("steps") == n, dict(w.health.counters)
    assert not any(k.startswith("dropped") for k in w.health.counters), dict(w.health.counters)
    got = streams(ListOutput.instances[-1].records)
    assert got["m"][-1][1]["n"] == n
