"""What feeds the dashboard: the router's newest estimates and health, drawn on a
terminal by `run_dashboard` (a fake terminal here, its frames counted, not timed)."""

from __future__ import annotations

import asyncio
import io

from rich.console import Console

from edged.records import Estimate, HealthRecord, Measurement
from edged.router import Router
from edged_demo.feed import NAME, LatestFeed
from edged_demo.live import run_dashboard

NOW = 1_796_426_323.0


def _stw(t: float, stw: float) -> Estimate:
    return Estimate("stw", "stw", t, {"stw": stw, "sog": stw, "stw_std": 0.1, "dvl_stw": None}, kind="stw")


def test_the_feed_keeps_the_newest_estimate_of_each_estimator_and_the_newest_health():
    router = Router()
    feed = LatestFeed(router, ["stw", "draft"])
    router.publish(_stw(NOW - 2, 4.0))
    router.publish(_stw(NOW - 1, 5.0))
    router.publish(Measurement("heading", "nmea", NOW, {"heading": 1.0}))  # not subscribed
    router.publish(HealthRecord(NOW - 1, {"t": NOW - 1, "ok": True}))
    assert feed.update() == 3
    snap = feed.snapshot()
    assert snap["estimates"]["stw"]["stw"] == 5.0 and snap["estimates"]["stw"]["kind"] == "stw"
    assert snap["estimates"]["stw"]["stale"] is False  # the payload as published
    assert snap["health"] == {"t": NOW - 1, "ok": True}
    assert feed.update() == 0 and feed.snapshot() == snap  # nothing new: the same view
    assert NAME in router.stats()["queues"]
    feed.close()
    assert NAME not in router.stats()["queues"]


def test_a_feed_nobody_drains_never_blocks_the_router():
    router = Router()
    feed = LatestFeed(router, ["stw"], maxsize=4)
    for i in range(10):
        router.publish(_stw(NOW + i, float(i)))
    assert router.stats()["queues"][NAME]["overflow"] == 6
    feed.update()
    assert feed.snapshot()["estimates"]["stw"]["stw"] == 3.0  # the newest it was given


def test_run_dashboard_draws_a_frame_per_refresh_on_a_terminal():
    router = Router()
    feed = LatestFeed(router, ["stw"])
    out = io.StringIO()
    console = Console(file=out, force_terminal=True, width=160, color_system=None)
    naps: list[float] = []

    async def sleep(s: float) -> None:  # the next frame's record arrives while it "sleeps"
        naps.append(s)
        router.publish(_stw(NOW, 5.0))

    asyncio.run(run_dashboard(feed, console, lambda: NOW, {"vessel_id": "v9"}, sleep=sleep, refreshes=2))
    text = out.getvalue()
    assert naps == [1.0]
    assert "no estimate yet" in text  # the first frame, before any estimate
    assert "9.72 kn  5.00 m/s" in text and "vessel v9" in text  # the second
