"""Times that cannot be true (issue 10): the plausible-time window of edged.timecheck,
the replay clock's last guard, the driver's refusal of what a reader let through, and
pacing that never sleeps through a gap in a log."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from core_dummies import ListOutput

from edged.cli import build_parser
from edged.clock import ReplayClock
from edged.commands import dispatch
from edged.config import parse_config
from edged.records import RawRecord
from edged import replay as replay_mod
from edged.replay import Replayer
from edged.runtime import Runtime
from edged.timecheck import AHEAD, EARLIEST, LATEST, TimeLimits, TimeWindow

T0 = 1_732_350_000.0  # 2024-11-23
MAX_WAIT = 10.0  # the documented bound of a pacing wait


# ---- the window ------------------------------------------------------------------
@pytest.mark.parametrize(
    "t", [math.nan, math.inf, -math.inf, -1.0, 0.0, 1e300, 20_000_000_000.0, EARLIEST - 1.0, LATEST + 1.0]
)
def test_the_default_window_refuses_times_that_cannot_be_true(t):
    w = TimeWindow()
    assert not w.accept(t)
    assert w.newest is None  # a refused time never moves the window
    assert w.accept(T0)


def test_a_time_more_than_a_day_after_the_newest_good_one_is_refused():
    w = TimeWindow()
    assert w.accept(T0)
    assert not w.accept(T0 + AHEAD + 1.0)
    assert w.accept(T0 - 3600.0)  # older is possible (reordering, a second source)
    assert w.accept(T0 + AHEAD)  # the top moves with the newest good time
    assert w.accept(T0 + 2 * AHEAD - 1.0)
    assert w.newest == T0 + 2 * AHEAD - 1.0


def test_a_run_of_agreeing_times_beyond_the_window_moves_it():
    w = TimeWindow(confirm=3)
    assert w.accept(T0)
    later = T0 + 7 * 86400
    assert [w.accept(later + i) for i in range(5)] == [False, False, True, True, True]
    assert w.newest == later + 4


def test_stray_times_between_good_ones_never_move_the_window():
    w = TimeWindow(confirm=3)
    assert w.accept(T0)
    for i in range(10):
        assert not w.accept(T0 + 7 * 86400 + i)
        assert w.accept(T0 + i)
    # times beyond the window that disagree with each other do not add up either
    assert not any(w.accept(T0 + (3 + 2 * i) * 86400) for i in range(10))
    assert w.newest == T0 + 9
    assert not TimeWindow(confirm=0).accept(math.nan)


def test_limits_are_configurable_and_checked():
    w = TimeWindow(TimeLimits(earliest=0.0, latest=1e6, ahead=10.0))
    assert w.accept(5.0) and w.accept(15.0) and not w.accept(26.0) and not w.accept(2e6)
    with pytest.raises(ValueError):
        TimeLimits(ahead=-1.0)
    with pytest.raises(ValueError):
        TimeLimits(latest=math.inf)
    with pytest.raises(ValueError):
        TimeLimits(earliest=math.nan)


def test_small_times_of_a_relative_log_do_not_anchor_the_one_day_rule():
    w = TimeWindow(earliest=0.0)
    assert w.accept(0.0) and w.accept(12.5)
    assert w.accept(T0)  # the one-day rule counts from dates only
    assert not w.accept(-0.5) and not w.accept(math.nan)


def test_the_replay_clock_never_jumps_to_a_time_that_is_not_finite():
    c = ReplayClock()
    c.advance_to(T0)
    for t in (math.nan, math.inf):
        c.advance_to(t)
        assert c.now() == T0
    c.advance_to(T0 + 1.0)
    assert c.now() == T0 + 1.0


# ---- the driver, through the CLI ---------------------------------------------------
CFG = """
[outputs.rec]
type = "list"
"""


def _run(registry, *argv: str) -> int:
    return dispatch(build_parser().parse_args(list(argv)), registry)


@pytest.mark.parametrize("bad", ["nan", "inf", "-1", "1e300", "20000000000.0"])
def test_the_driver_refuses_a_time_its_reader_let_through(registry, write_config, tmp_path, capsys, bad):
    # The dummy reader takes float() of anything: the driver is the last guard.
    log = tmp_path / "gyro.log"
    log.write_text(f"#dummy\n{T0} yaw_rate r=1\n{bad} yaw_rate r=2\n{T0 + 2} yaw_rate r=3\n")
    ListOutput.instances.clear()
    rc = _run(registry, "replay", str(log), "-c", str(write_config(CFG)), "--no-zenoh", "--no-progress")
    out = capsys.readouterr().out
    assert rc == 0, out
    raws = [r for r in ListOutput.instances[0].records if isinstance(r, RawRecord)]
    assert [r.t for r in raws] == [T0, T0 + 2]
    assert "replayed 2 records, 2.0 s of data" in out
    assert any(line.split()[-2:] == ["rejected.bad_time", "1"] for line in out.splitlines()), out


# ---- pacing ---------------------------------------------------------------------
class FakeSleep:
    """Records the delays the pacing asks for and returns at once."""

    def __init__(self) -> None:
        self.delays: list[float] = []

    async def __call__(self, delay: float) -> None:
        self.delays.append(delay)


async def _paced(registry, path: Path, speed: float, **kw) -> tuple[Replayer, FakeSleep]:
    rt = Runtime(parse_config({"outputs": {"rec": {"type": "list"}}}, registry), registry, ReplayClock(), replay=True)
    sleep = FakeSleep()
    rep = Replayer(rt, [path], speed=speed, sleep=sleep, **kw)
    await rt.start()
    try:
        await rep.run()
    finally:
        await rt.stop()
    return rep, sleep


async def test_pacing_skips_a_long_gap_instead_of_sleeping_through_it(registry, tmp_path, caplog):
    log = tmp_path / "gyro.log"
    # An hour's pause in the log: at --speed 1 that would be an hour of waiting.
    log.write_text(f"#dummy\n{T0} yaw_rate r=1\n{T0 + 1} yaw_rate r=2\n{T0 + 3601} yaw_rate r=3\n{T0 + 3602} yaw_rate r=4\n")
    rep, sleep = await _paced(registry, log, 1.0)
    assert getattr(replay_mod, "MAX_WAIT", None) == MAX_WAIT
    assert rep.stats.records == 4
    assert sleep.delays and max(sleep.delays) <= MAX_WAIT
    assert sum(sleep.delays) < 3.0  # the two 1-second steps, not the hour
    assert rep.stats.gaps_skipped == 1
    assert sum("skipped, not waited for" in r.getMessage() for r in caplog.records) == 1
    raws = [r for r in ListOutput.instances[-1].records if isinstance(r, RawRecord)]
    assert [r.t for r in raws] == [T0, T0 + 1, T0 + 3601, T0 + 3602]


async def test_a_gap_shorter_than_the_bound_is_waited_for(registry, tmp_path):
    log = tmp_path / "gyro.log"
    log.write_text(f"#dummy\n{T0} yaw_rate r=1\n{T0 + 500} yaw_rate r=2\n")
    rep, sleep = await _paced(registry, log, 100.0)  # 5 s of wall time: waited
    assert rep.stats.gaps_skipped == 0
    assert 4.0 < max(sleep.delays) <= 5.0
    rep, sleep = await _paced(registry, log, 100.0, max_wait=1.0)  # the bound is a parameter
    assert rep.stats.gaps_skipped == 1 and all(d <= 1.0 for d in sleep.delays)


def test_the_summary_says_what_the_replay_refused_and_skipped(registry):
    import io as _io

    from edged.clock import ReplayClock
    from edged.replaysummary import print_summary
    from edged.config import parse_config
    from edged.replay import ReplayStats
    from edged.runtime import Runtime

    rt = Runtime(parse_config({}, registry), registry, ReplayClock(), replay=True)
    out = _io.StringIO()
    print_summary(rt, ReplayStats(records=5, t_first=1.0, t_last=2.0, bad_time=2, gaps_skipped=1), out)
    text = out.getvalue()
    assert "time that cannot be true: 2" in text and "skipped instead of waited for (--speed pacing): 1" in text
