"""The systemd notify protocol (issue 16): READY once started, the watchdog fed only
while the event loop and every plugin task live, STOPPING at the stop; tested against
a fake notify socket (systemd need not run here)."""

from __future__ import annotations

import asyncio
import logging
import socket
import time
from pathlib import Path

import pytest
from core_dummies import ListOutput

from edged.clock import ManualClock
from edged.runcmd import run_daemon
from edged.config import parse_config
from edged.runtime import Runtime
from edged.sdnotify import Notifier, feed_watchdog, watchdog_period


@pytest.fixture
def manager(tmp_path: Path):
    """A fake service manager: the notify socket and what reached it."""
    path = str(tmp_path / "notify")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(path)
    sock.setblocking(False)
    yield path, sock
    sock.close()


def _received(sock: socket.socket) -> list[str]:
    out = []
    while True:
        try:
            out.append(sock.recv(4096).decode())
        except BlockingIOError:
            return out


def test_a_notification_is_one_datagram_of_key_value_lines(manager):
    path, sock = manager
    n = Notifier(env={"NOTIFY_SOCKET": path})
    assert n.enabled and n.ready("running: 3 inputs") and n.watchdog() and n.stopping()
    assert _received(sock) == ["READY=1\nSTATUS=running: 3 inputs\n", "WATCHDOG=1\n", "STOPPING=1\n"]
    n.close()


def test_an_abstract_socket_name_is_understood():
    name = f"edged-test-{time.monotonic_ns()}"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(b"\0" + name.encode())
    try:
        assert Notifier(env={"NOTIFY_SOCKET": "@" + name}).ready()
        assert sock.recv(100) == b"READY=1\n"
    finally:
        sock.close()


def test_outside_systemd_nothing_is_sent_and_a_gone_manager_is_said_once(tmp_path, caplog):
    assert not Notifier(env={}).enabled and not Notifier(env={}).ready()
    gone = Notifier(env={"NOTIFY_SOCKET": str(tmp_path / "nobody")})
    with caplog.at_level(logging.WARNING, logger="edged.sdnotify"):
        assert not gone.watchdog() and not gone.watchdog()
    assert caplog.text.count("event=notify-failed") == 1


@pytest.mark.parametrize(("env", "want"), [
    ({}, None),
    ({"WATCHDOG_USEC": "30000000"}, 30.0),
    ({"WATCHDOG_USEC": "2000000", "WATCHDOG_PID": "4242"}, 2.0),
    ({"WATCHDOG_USEC": "2000000", "WATCHDOG_PID": "1"}, None),  # meant for another process
    ({"WATCHDOG_USEC": "soon"}, None),
    ({"WATCHDOG_USEC": "0"}, None),
])
def test_the_watchdog_period_is_read_from_the_environment(env, want):
    assert watchdog_period(env, pid=4242) == want


async def test_the_watchdog_is_withheld_while_a_task_has_ended_and_fed_again_after(manager, caplog):
    path, sock = manager
    n = Notifier(env={"NOTIFY_SOCKET": path})
    dead_at = {2: ["input:gps"], 3: ["input:gps"]}  # ticks 2 and 3: a plugin task ended
    ticks = 0
    slept: list[float] = []

    async def sleep(d: float) -> None:
        nonlocal ticks
        slept.append(d)
        ticks += 1
        if ticks > 5:
            raise asyncio.CancelledError
        await asyncio.sleep(0)

    with caplog.at_level(logging.ERROR, logger="edged.sdnotify"), pytest.raises(asyncio.CancelledError):
        await feed_watchdog(n, 10.0, lambda: dead_at.get(ticks, []), sleep=sleep)
    assert slept[0] == 5.0  # half the period
    assert _received(sock) == ["WATCHDOG=1\n"] * 3  # ticks 1, 4, 5
    assert caplog.text.count("event=watchdog-withheld tasks=input:gps") == 1


def _runtime(registry):
    return Runtime(parse_config({"outputs": {"rec": {"type": "list"}}}, registry), registry,
                   ManualClock(1_700_000_000.0))


async def test_the_daemon_says_ready_feeds_the_watchdog_and_says_stopping(registry, manager, monkeypatch):
    path, sock = manager
    monkeypatch.setenv("WATCHDOG_USEC", "100000")  # 0.1 s: fed every 0.05 s
    monkeypatch.delenv("WATCHDOG_PID", raising=False)
    rt = _runtime(registry)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    got: list[str] = []

    async def manager_side() -> None:
        while got.count("WATCHDOG=1\n") < 3:
            got.append((await loop.sock_recv(sock, 4096)).decode())
        stop.set()

    side = asyncio.ensure_future(manager_side())
    assert await asyncio.wait_for(run_daemon(rt, stop, notifier=Notifier(path)), 10.0) == 0
    await side
    got += _received(sock)
    assert got[0].startswith("READY=1\nSTATUS=running: vessel ")
    assert got[-1] == "STOPPING=1\n" and got.count("WATCHDOG=1\n") >= 3


async def test_a_wedged_event_loop_stops_the_watchdog(registry, manager, monkeypatch):
    """A step that holds the loop for three periods: not one WATCHDOG=1 goes out while
    it holds it (systemd would restart the daemon), and they come again after."""
    path, sock = manager
    monkeypatch.setenv("WATCHDOG_USEC", "100000")
    monkeypatch.delenv("WATCHDOG_PID", raising=False)
    rt = _runtime(registry)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    stamps: list[tuple[float, str]] = []
    held: list[float] = []

    def wedge() -> None:  # in the loop: nothing else runs meanwhile
        t0 = time.monotonic()
        time.sleep(0.3)
        held.extend([t0, time.monotonic()])

    async def manager_side() -> None:
        while True:
            text = (await loop.sock_recv(sock, 4096)).decode()
            stamps.append((time.monotonic(), text))
            if text == "WATCHDOG=1\n":
                if not held:
                    loop.call_soon(wedge)
                elif sum(1 for t, x in stamps if x == "WATCHDOG=1\n" and t > held[1]) >= 2:
                    stop.set()
                    return

    side = asyncio.ensure_future(manager_side())
    assert await asyncio.wait_for(run_daemon(rt, stop, notifier=Notifier(path)), 10.0) == 0
    await side
    # What was sent while the loop was held reached the socket after it; the manager
    # reads it at once, so every stamp is outside the hold, and the first after it
    # is at least the hold's length after the last before it.
    dogs = [t for t, x in stamps if x == "WATCHDOG=1\n"]
    before = max(t for t in dogs if t <= held[0])
    after = min(t for t in dogs if t >= held[1])
    assert after - before >= 0.3
    assert not [t for t in dogs if held[0] < t < held[1]]


@pytest.fixture
def registry():
    from edged.registry import Registry

    r = Registry(use_entry_points=False)
    r.register("outputs", "list", ListOutput)
    return r


async def test_a_plugin_task_that_ended_is_named_for_the_watchdog(registry):
    from core_dummies import DummyInput

    registry.register("inputs", "dummy", DummyInput)
    rt = Runtime(parse_config({"inputs": {"g": {"type": "dummy", "lines": []}}, "outputs": {"rec": {"type": "list"}}},
                              registry), registry, ManualClock(1_700_000_000.0))
    await rt.start()
    try:
        assert rt.ended_tasks() == []
        task = next(t for t in rt._tasks if t.get_name() == "input:g")
        task.cancel()  # as if its supervisor had ended
        await asyncio.gather(task, return_exceptions=True)
        assert rt.ended_tasks() == ["input:g"]
    finally:
        await rt.stop()
