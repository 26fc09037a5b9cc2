"""Loss that health must show: a UDP flood the kernel drops, a full datagram queue, and
serial sentences that waited in the port while it was closed (issue 10)."""

from __future__ import annotations

import asyncio
import os
import socket
import tty
from types import SimpleNamespace

import pytest

from edged_nmea0183.config import Nmea0183Config
from nmea_rig import NOW, TIMEOUT, make
from edged_nmea0183.transports import udp as udp_mod
from edged_nmea0183.transports.udp import UdpTransport, kernel_drops, proc_drops

HDT = b"$HEHDT,274.07,T*19"
GGA = b"$GPGGA,094736,5251.0094,N,00518.8172,E,1,12,0.60,-4,M,46.8,M,,*4B"
linux = pytest.mark.skipif(not os.path.exists("/proc/net/udp"), reason="kernel drop counters are Linux's")




async def stop(task: asyncio.Task) -> None:
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# -- UDP ------------------------------------------------------------------------------
FLOOD = 600  # datagrams: far more than an 8 KiB receive buffer holds


@linux
def test_udp_flood_kernel_drops_are_counted_in_health(event_health):
    async def main() -> None:
        port = free_udp_port()
        plugin, sink = make(event_health, transport="udp", port=port)
        plugin.transport.rcvbuf = 4096  # the smallest buffer: the kernel makes it ~8 KiB
        task = asyncio.create_task(plugin.run())
        try:
            await event_health.wait_state("connected")
            assert plugin.status()["rcvbuf"] <= 16384
            assert event_health.counters["dropped.kernel"] == 0  # measured, none yet
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                # The loop does not run while this loop sends: nothing reads the socket.
                for i in range(FLOOD):
                    s.sendto(HDT + b"\r\n", ("127.0.0.1", port))
            plugin.status()  # a health snapshot: the drops are known before any read
            dropped = event_health.counters["dropped.kernel"]
            assert 0 < dropped < FLOOD
            await sink.wait_raw(FLOOD - dropped)  # every datagram is received or counted
            plugin.status()
            snap = event_health.snapshot()
        finally:
            await stop(task)
        assert len(sink.raw) == FLOOD - dropped
        assert snap["counters"]["dropped.kernel"] == dropped
        assert snap["counters"]["dropped.queue"] == 0
        assert "dropped.kernel" in snap["last_error"] and "rcvbuf" in snap["last_error"]
        # The link stays connected (it delivers); the loss is in the counters and rates.
        assert snap["state"] == "connected"

    asyncio.run(main())


@linux
def test_udp_kernel_drops_survive_a_reopen(event_health):
    """The totals are the transport's across sockets: a watchdog reopen loses nothing."""

    async def main() -> None:
        t = UdpTransport("127.0.0.1", 0, rcvbuf=4096)
        await t.open()
        port = t.local_port
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for _ in range(FLOOD):
                s.sendto(HDT, ("127.0.0.1", port))
        await t.close()  # no look at the counter before: close takes the last one
        first = t.kernel_dropped
        assert first > 0
        await t.open()  # another socket (port 0: the old one closes on the next loop turn)
        assert t.counters()["dropped.kernel"] == first  # a new socket starts at 0: no double count
        await t.close()

    asyncio.run(main())


@linux
def test_proc_net_udp_fallback_matches_the_socket_counter():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as r, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        r.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        r.bind(("127.0.0.1", 0))
        for _ in range(FLOOD):
            s.sendto(HDT, r.getsockname())
        n = kernel_drops(r)
        assert n is not None and n > 0
        assert proc_drops(r) == n


def test_proc_net_udp_missing_or_foreign_is_unknown(tmp_path):
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as r:
        r.bind(("127.0.0.1", 0))
        assert proc_drops(r, str(tmp_path)) is None  # no /proc
        (tmp_path / "udp").write_text("  sl  local_address ...\n   0: 0100007F:1F90 00000000:0000 07 x x x 0 0 1 2 p 5\n")
        assert proc_drops(r, str(tmp_path)) is None  # not our inode


def test_udp_queue_overflow_reaches_health(event_health, monkeypatch):
    """The transport's own drop count (its queue to the framer full) is in health."""
    monkeypatch.setattr(udp_mod, "QUEUE_SIZE", 5)

    async def main() -> None:
        plugin, _ = make(event_health, transport="udp", port=free_udp_port())
        t = plugin.transport
        t.port = 0
        await t.open()  # opened by hand: nothing reads the queue
        try:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                for _ in range(20):
                    s.sendto(HDT, ("127.0.0.1", t.local_port))
            while t.dropped < 15:  # the protocol callback runs once per datagram
                await asyncio.sleep(0)
            plugin.status()
        finally:
            await t.close()
        assert event_health.counters["dropped.queue"] == 15
        assert "dropped.queue" in event_health.last_error

    asyncio.run(main())


def test_rcvbuf_from_configuration():
    cfg = SimpleNamespace(bind="127.0.0.1", port=10110, broadcast=False, rcvbuf=1 << 20)
    assert UdpTransport.from_config(cfg).rcvbuf == 1 << 20
    del cfg.rcvbuf  # a configuration from before the key existed
    assert UdpTransport.from_config(cfg).rcvbuf is None


def test_rcvbuf_is_applied_to_the_socket():
    async def main() -> None:
        small, big = UdpTransport("127.0.0.1", 0, rcvbuf=4096), UdpTransport("127.0.0.1", 0, rcvbuf=100_000)
        await small.open()
        await big.open()
        try:
            assert small.info()["rcvbuf"] < big.info()["rcvbuf"]
            assert big.info()["rcvbuf"] >= 100_000 or big.info()["rcvbuf"] >= _rmem_max()
        finally:
            await small.close()
            await big.close()

    asyncio.run(main())


def _rmem_max() -> int:
    try:
        with open("/proc/sys/net/core/rmem_max") as f:
            return 2 * int(f.read())
    except OSError:
        return 0


# -- serial ---------------------------------------------------------------------------
async def no_wait(_: float) -> None:
    await asyncio.sleep(0)


def test_serial_keeps_what_the_device_sent_before_the_port_opened(event_health):
    """Sentences that wait in the port's input buffer are not flushed by the open."""

    async def main() -> None:
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)  # a serial line, as the previous session left it
        device = os.ttyname(slave)
        os.write(master, GGA + b"\r\n" + HDT + b"\r\n")  # before anyone opens the device
        plugin, sink = make(event_health, no_wait, transport="serial", device=device, baudrate=38400)
        task = asyncio.create_task(plugin.run())
        try:
            await sink.wait_raw(2)
        finally:
            await stop(task)
            os.close(slave)
            os.close(master)
        assert [r.data for r in sink.raw] == [GGA, HDT]

    asyncio.run(main())


def test_serial_reopen_keeps_the_sentences_sent_while_closed(event_health):
    """The watchdog closes a silent port; what arrives before the reopen is read."""

    async def main() -> None:
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        device = os.ttyname(slave)
        waits = 0

        async def sleep(_: float) -> None:  # the backoff: the port is closed now
            nonlocal waits
            waits += 1
            if waits == 1:
                os.write(master, HDT + b"\r\n" + GGA + b"\r\n")
            await asyncio.sleep(0)

        plugin, sink = make(event_health, sleep, transport="serial", device=device, baudrate=38400, watchdog=0.2)
        task = asyncio.create_task(plugin.run())
        try:
            await event_health.wait_state("connected")
            os.write(master, GGA + b"\r\n")
            await sink.wait_raw(1)
            await event_health.wait_state("stale")  # silent: closed, then reopened
            await sink.wait_raw(3)
        finally:
            await stop(task)
            os.close(slave)
            os.close(master)
        assert [r.data for r in sink.raw] == [GGA, HDT, GGA]
        assert event_health.counters["connects"] >= 2

    asyncio.run(main())


def test_serial_user_flush_still_flushes(tmp_path):
    from edged.serialport import open_keeping_input

    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    try:
        os.write(master, HDT + b"\r\n")
        port = open_keeping_input(os.ttyname(slave), 38400)
        try:
            import select

            # the pty hands the bytes over in its own time: wait for them (bounded)
            want = len(HDT) + 2
            for _ in range(500):
                if port.in_waiting >= want:
                    break
                select.select([port.fileno()], [], [], 0.01)
            assert port.in_waiting == want  # kept by the open
            port.reset_input_buffer()
            assert port.in_waiting == 0
        finally:
            port.close()
    finally:
        os.close(slave)
        os.close(master)


def test_rcvbuf_is_validated_by_the_configuration():
    import pytest as _pytest
    from pydantic import ValidationError

    from edged_nmea0183.config import Nmea0183Config

    assert Nmea0183Config.model_validate({"type": "nmea0183", "transport": "udp", "port": 10110, "rcvbuf": 1 << 20}).rcvbuf == 1 << 20
    for bad in (100, -1, 2**40, "big"):
        with _pytest.raises(ValidationError):
            Nmea0183Config.model_validate({"type": "nmea0183", "transport": "udp", "port": 10110, "rcvbuf": bad})


async def test_a_socket_failure_during_a_flood_is_not_lost():
    """The failure arrives while the queue is full: it must still end the link after
    the queued datagrams are read, not vanish in the event loop's callback."""
    from edged_nmea0183.transports.udp import UdpTransport, _Receiver

    t = UdpTransport("127.0.0.1", 9)
    t._queue = asyncio.Queue(maxsize=2)
    rx = _Receiver(t._queue, t)
    rx.datagram_received(b"a", None)
    rx.datagram_received(b"b", None)
    rx.connection_lost(OSError("network is down"))  # the queue is full
    assert [await t.read(), await t.read()] == [b"a", b"b"]
    with pytest.raises(OSError, match="network is down"):
        await t.read()
