"""The live input over python-can's `virtual` bus: end to end, errors, bus-off, watchdog.

There is no SocketCAN on the test machines; the socketcan path differs only in the
interface name python-can is given. The backoff sleep is injected: tests see the
delays the plugin chose without waiting them out.
"""

from __future__ import annotations

import asyncio
import itertools
import math
import struct
from typing import Any, Callable

import can
import pytest
from can.interfaces.virtual import VirtualBus

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged.records import Measurement, RawRecord
from edged_can.config import CanConfig
from edged_can.plugin import CanInput

TIMEOUT = 10.0  # safety net only
_channels = itertools.count()


class Sink(list):
    """`publish` is list.append; an event fires once `n` measurements arrived."""

    def __init__(self, n: int) -> None:
        super().__init__()
        self.n = n
        self.enough = asyncio.Event()

    def append(self, rec: Any) -> None:
        super().append(rec)
        if sum(isinstance(r, Measurement) for r in self) >= self.n:
            self.enough.set()


class Harness:
    def __init__(self, n_measurements: int = 1, **cfg: Any) -> None:
        self.channel = f"edged-test-{next(_channels)}"
        self.config = CanConfig.model_validate(
            {"type": "can", "interface": "virtual", "channel": self.channel, **cfg}
        )
        self.clock = ManualClock(1732350000.0)
        self.health = ComponentHealth("can0", "input", "can", self.clock)
        self.sink = Sink(n_measurements)
        ctx = PluginContext(name="can0", clock=self.clock, health=self.health, publish=self.sink.append)
        ctx.decoder = CanInput.make_decoder("can0", self.config, self.health)
        self.plugin = CanInput(self.config, ctx)
        self.delays: list[float] = []
        self.sleeps = asyncio.Event()
        self.sleeps_wanted = 1
        self.opened = asyncio.Event()
        self.open_bus: Callable[..., can.BusABC] = can.Bus
        self.plugin.sleep = self._sleep
        self.plugin.open_bus = self._open

    def _open(self, **kw: Any) -> can.BusABC:
        bus = self.open_bus(**kw)
        self.opened.set()
        return bus

    async def _sleep(self, delay: float) -> None:
        self.delays.append(delay)
        if len(self.delays) >= self.sleeps_wanted:
            self.sleeps.set()
        await asyncio.sleep(0)

    async def run_until(self, event: asyncio.Event) -> None:
        task = asyncio.create_task(self.plugin.run())
        try:
            await asyncio.wait_for(event.wait(), TIMEOUT)
        finally:
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task


def _frames() -> list[can.Message]:
    heading = struct.pack("<BHhhB", 0, round(math.radians(45.0) / 1e-4), 0x7FFF, 0x7FFF, 0xFC)
    return [
        can.Message(arbitration_id=0x310, data=struct.pack("<HBB", 7250, 0, 1), is_extended_id=False),
        can.Message(arbitration_id=0x320, data=struct.pack("<hhh", 100, -200, 300), is_extended_id=False),
        can.Message(arbitration_id=0x321, data=struct.pack("<ihh", 50_000, 0, 0), is_extended_id=False),
        can.Message(arbitration_id=(2 << 26) | (127250 << 8) | 28, data=heading, is_extended_id=True),
    ]


async def test_frames_sent_on_a_virtual_bus_become_measurements():
    h = Harness(n_measurements=4, watchdog=30.0)

    async def send() -> None:
        await h.opened.wait()
        with can.Bus(interface="virtual", channel=h.channel) as tx:
            for msg in _frames():
                tx.send(msg)

    sender = asyncio.create_task(send())
    await h.run_until(h.sink.enough)
    await sender
    meas = [r for r in h.sink if isinstance(r, Measurement)]
    raws = [r for r in h.sink if isinstance(r, RawRecord)]
    assert [(m.kind, m.source) for m in meas] == [
        ("draft", "can0.DraftMark"),
        ("accel_body", "can0.ImuAccel"),
        ("yaw_rate", "can0.ImuRate"),
        ("heading", "can0.28"),
    ]
    assert meas[0].values == {"mark": "fore_port", "draft": pytest.approx(7.25), "status": 0}
    assert meas[1].values == {"ax": pytest.approx(0.1), "ay": pytest.approx(-0.2), "az": pytest.approx(0.3)}
    assert meas[2].values == {"r": pytest.approx(0.05)}
    assert meas[3].values["heading"] == pytest.approx(math.radians(45.0), abs=1e-4)
    assert all(m.t == 1732350000.0 for m in meas)  # stamped by ctx.clock
    assert raws[3] == RawRecord("can", "can0", 1732350000.0, bytes(_frames()[3].data), {"id": 0x09F1121C, "ext": True})
    assert h.health.state == "connected"  # the shared link states (edged.link)
    assert h.health.snapshot()["ok"] is True
    assert h.health.counters["frames"] == 4
    assert h.health.counters["connects"] == 1


async def test_a_silent_bus_is_reopened_by_the_watchdog_with_growing_backoff():
    h = Harness(watchdog=0.05, backoff_initial=0.5, backoff_max=1.5)
    h.sleeps_wanted = 4
    await h.run_until(h.sleeps)
    assert h.delays[:4] == [0.5, 1.0, 1.5, 1.5]
    assert h.health.counters["watchdog"] >= 4
    assert h.health.counters["disconnects"] >= 4
    assert h.plugin.sessions >= 4
    assert "no frame for 0.05 s" in h.health.last_error


class _DownBus(VirtualBus):
    """A bus whose interface went down: every receive fails."""

    def _recv_internal(self, timeout: float | None) -> tuple[None, bool]:
        raise can.CanOperationError("Network is down")


# python-can's Notifier re-raises the receive error in its thread after reporting it.
@pytest.mark.filterwarnings("ignore::pytest.PytestUnhandledThreadExceptionWarning")
async def test_a_bus_error_is_reported_and_the_bus_reopened():
    h = Harness(n_measurements=1, watchdog=30.0)
    opened = 0

    def open_bus(**kw: Any) -> can.BusABC:
        nonlocal opened
        opened += 1
        if opened == 1:
            return _DownBus(channel=kw["channel"])
        return can.Bus(**kw)

    h.open_bus = open_bus

    async def send_after_reopen() -> None:
        await h.sleeps.wait()
        h.opened.clear()
        await h.opened.wait()
        with can.Bus(interface="virtual", channel=h.channel) as tx:
            tx.send(_frames()[0])

    sender = asyncio.create_task(send_after_reopen())
    await h.run_until(h.sink.enough)
    await sender
    assert h.health.counters["bus.errors"] == 1
    assert h.health.counters["disconnects"] == 1
    assert h.health.counters["connects"] == 2
    assert h.delays == [0.5]
    assert "Network is down" in h.health.last_error
    assert [r.kind for r in h.sink if isinstance(r, Measurement)] == ["draft"]


async def test_bus_off_is_reported_in_health_and_the_bus_reopened():
    h = Harness(watchdog=30.0)
    states: list[str] = []

    async def send_bus_off() -> None:
        await h.opened.wait()
        with can.Bus(interface="virtual", channel=h.channel) as tx:
            tx.send(_frames()[0])
            tx.send(can.Message(arbitration_id=0x40, data=bytes(8), is_error_frame=True))
        await h.sleeps.wait()
        states.append(h.health.state)

    sender = asyncio.create_task(send_bus_off())
    await h.run_until(h.sleeps)
    await sender
    c = h.health.counters
    assert (c["bus.error_frames"], c["bus.bus_off"], c["disconnects"]) == (1, 1, 1)
    assert states == ["disconnected"]  # bus-off is the reason, not a state of its own
    assert h.delays == [0.5]  # frames had flowed: the backoff starts over
    assert "bus-off" in h.health.last_error


async def test_an_interface_that_cannot_be_opened_is_retried_with_backoff():
    h = Harness(backoff_initial=0.25, backoff_max=10.0)
    h.sleeps_wanted = 3

    def no_such_interface(**kw: Any) -> can.BusABC:
        raise OSError(19, "No such device")

    h.open_bus = no_such_interface
    await h.run_until(h.sleeps)
    assert h.delays[:3] == [0.25, 0.5, 1.0]
    assert h.health.counters["connect_failures"] >= 3
    assert h.health.state == "disconnected"
    assert h.health.snapshot()["ok"] is False
    assert "No such device" in h.health.last_error
