"""Router: fan-out by kind and source, overflow and late counting, source failover."""

from __future__ import annotations

import asyncio

import pytest

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.records import Estimate, Measurement, RawRecord
from edged.router import BoundedQueue, Router


def hdg(source: str, t: float, h: float = 1.0) -> Measurement:
    return Measurement("heading", source, t, {"heading": h})


def test_fan_out_by_kind_and_source():
    r = Router()
    a = r.subscribe("a", ["heading"])
    b = r.subscribe("b", ["heading", "yaw_rate"], sources=["gyro"])
    allsub = r.subscribe("all", None, preferred_only=False)
    raw = RawRecord("nmea0183", "gyro", 1.0, b"$HEHDT,1.0,T*00")
    m1, m2 = hdg("gyro", 1.0), hdg("gnss", 1.1)
    rot = Measurement("yaw_rate", "gyro", 1.2, {"r": 0.01})
    est = Estimate("stw", "stw", 1.3, {"stw": 5.0})
    for rec in (raw, m1, m2, rot, est):
        r.publish(rec)
    assert a.queue.drain_nowait() == [m1, m2]
    assert b.queue.drain_nowait() == [m1, rot]
    assert allsub.queue.drain_nowait() == [raw, m1, m2, rot, est]


def test_subscribe_after_publish_sees_new_records():
    r = Router()
    r.publish(hdg("gyro", 1.0))
    late_sub = r.subscribe("x", ["heading"])
    r.publish(hdg("gyro", 2.0))
    assert [m.t for m in late_sub.queue.drain_nowait()] == [2.0]


def test_overflow_is_counted_per_subscriber_and_never_blocks():
    h = ComponentHealth("slow", "estimator", "t", ManualClock())
    r = Router()
    slow = r.subscribe("slow", ["heading"], maxsize=3, health=h)
    fast = r.subscribe("fast", ["heading"], maxsize=100)
    for i in range(10):
        r.publish(hdg("gyro", float(i)))
    assert len(slow.queue) == 3 and slow.overflow == 7 and h.counters["overflow"] == 7
    assert len(fast.queue) == 10 and fast.overflow == 0
    # the oldest are kept: nothing already queued is lost
    assert [m.t for m in slow.queue.drain_nowait()] == [0.0, 1.0, 2.0]


def test_late_records_counted_and_dropped_within_window():
    h = ComponentHealth("w", "estimator", "t", ManualClock())
    r = Router()
    strict = r.subscribe("strict", ["heading"], reorder_window=0.0, health=h)
    loose = r.subscribe("loose", ["heading"], reorder_window=0.5)
    out = r.subscribe("out", None, preferred_only=False)
    for t in (1.0, 2.0, 1.7, 1.2, 2.5):
        r.publish(hdg("gyro", t))
    assert [m.t for m in strict.queue.drain_nowait()] == [1.0, 2.0, 2.5]
    assert strict.late == 2 and h.counters["late"] == 2
    assert [m.t for m in loose.queue.drain_nowait()] == [1.0, 2.0, 1.7, 2.5]
    assert loose.late == 1
    assert len(out.queue) == 5  # outputs record everything


def test_source_priority_failover_and_give_back():
    r = Router()
    r.set_priority("heading", ["gyro", "gnss"], timeout=2.0)
    est = r.subscribe("est", ["heading"])
    rec = r.subscribe("rec", ["heading"], preferred_only=False)
    seq = [
        hdg("gyro", 0.0), hdg("gnss", 0.1),  # both alive: gyro wins
        hdg("gyro", 1.0), hdg("gnss", 1.1),
        hdg("gnss", 2.1),  # gyro silent 1.1 s: not yet stale
        hdg("gnss", 3.1),  # gyro silent 2.1 s > 2.0: gnss takes over
        hdg("gnss", 4.1),
        hdg("gyro", 4.5),  # gyro back: gives back at once
        hdg("gnss", 4.6),
    ]
    for m in seq:
        r.publish(m)
    got = [(m.source, m.t) for m in est.queue.drain_nowait()]
    assert got == [("gyro", 0.0), ("gyro", 1.0), ("gnss", 3.1), ("gnss", 4.1), ("gyro", 4.5)]
    assert len(rec.queue) == len(seq)
    assert r.priorities["heading"].switches == 2
    assert r.stats()["active_sources"] == {"heading": "gyro"}
    assert r.suppressed == 4


def test_unlisted_source_ranks_last():
    r = Router()
    r.set_priority("heading", ["gyro"], timeout=1.0)
    est = r.subscribe("est", ["heading"])
    for m in (hdg("other", 0.0), hdg("gyro", 0.5), hdg("other", 1.0), hdg("other", 2.0)):
        r.publish(m)
    assert [(m.source, m.t) for m in est.queue.drain_nowait()] == [
        ("other", 0.0),
        ("gyro", 0.5),
        ("other", 2.0),
    ]


@pytest.mark.parametrize("n", [65, 1000, 10_000])
def test_a_priority_forgets_sources_silent_for_long_and_still_fails_over(n):
    """A replay of n one-minute files of one kind, each file its own source: the
    priority keeps the recent sources only (each record no longer walks all n), and
    the order of the listed ones still rules."""
    r = Router()
    r.set_priority("heading", ["gyro"], timeout=2.0)
    est = r.subscribe("est", ["heading"], maxsize=2 * n)
    for j in range(n):
        r.publish(hdg(f"file{j}", 60.0 * j))
    prio = r.priorities["heading"]
    assert len(prio.last_seen) <= 65
    r.publish(hdg("gyro", 60.0 * n))
    r.publish(hdg(f"file{n}", 60.0 * n + 0.5))  # the gyro alive: ranked first
    got = [(m.source, m.t) for m in est.queue.drain_nowait()]
    assert got[-1] == ("gyro", 60.0 * n)
    assert ("file%d" % n, 60.0 * n + 0.5) not in got


async def test_bounded_queue_wakes_consumer_and_batches():
    q = BoundedQueue(10)
    task = asyncio.ensure_future(q.get_batch(max_items=3))
    await asyncio.sleep(0)
    assert not task.done()
    for i in range(5):
        assert q.put(i)
    assert await asyncio.wait_for(task, 1.0) == [0, 1, 2]
    assert await q.get_batch() == [3, 4]


def test_excluded_keys_never_reach_a_catch_all_subscriber():
    r = Router()
    pub = r.subscribe("publisher", None, exclude=["raw"], preferred_only=False)
    m = hdg("gyro", 1.0)
    r.publish(RawRecord("nmea0183", "gyro", 1.0, b"$HEHDT,1.0,T*00"))
    r.publish(m)
    assert pub.queue.drain_nowait() == [m]
