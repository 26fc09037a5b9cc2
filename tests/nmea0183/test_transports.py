"""End to end through each transport: serial (pty), TCP, UDP, file; reconnect, watchdog,
backoff. Every wait is on an event with a timeout as safety net, never a sleep-poll.
"""

from __future__ import annotations

import asyncio
import os
import socket
import tty

import pytest

from nmea_rig import NOW, TIMEOUT, make

HDT = b"$HEHDT,274.07,T*19"
GGA = b"$GPGGA,094736,5251.0094,N,00518.8172,E,1,12,0.60,-4,M,46.8,M,,*4B"




async def no_wait(_: float) -> None:
    await asyncio.sleep(0)


async def stop(task: asyncio.Task) -> None:
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_tcp_receives_reconnects_after_peer_goes_away(event_health):
    async def main() -> None:
        conns: list[int] = []

        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            conns.append(1)
            if len(conns) == 1:
                writer.write(GGA + b"\r\n" + HDT[:9])  # a partial line, then the peer goes away
            else:
                writer.write(b"274.07,T*19\r\n" + HDT + b"\r\n")  # must not join the fragment
            await writer.drain()
            writer.close()

        server = await asyncio.start_server(serve, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        plugin, sink = make(event_health, no_wait, transport="tcp", host="127.0.0.1", port=port)
        task = asyncio.create_task(plugin.run())
        try:
            await sink.wait_raw(2)
            await event_health.wait_state("connected", 2)
        finally:
            await stop(task)
            server.close()
        assert [r.data for r in sink.raw] == [GGA, HDT]
        assert all(r.t == NOW and r.protocol == "nmea0183" and r.source == "gnss1" for r in sink.raw)
        assert [m.kind for m in sink.measurements] == ["position", "heading"]
        c = event_health.counters
        assert c["connects"] >= 2 and c["disconnects"] >= 1
        assert c["bytes"] == len(GGA) + 2 + 9 + 13 + len(HDT) + 2
        assert c["rejected.no_start"] == 1  # the tail "274.07,T*19" on its own
        assert "disconnected" in event_health.history

    asyncio.run(main())


def test_watchdog_reopens_a_silent_link(event_health):
    async def main() -> None:
        conns: list[asyncio.StreamWriter] = []

        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            conns.append(writer)  # open, but silent

        server = await asyncio.start_server(serve, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        plugin, _ = make(event_health, no_wait, transport="tcp", host="127.0.0.1", port=port, watchdog=0.2)
        task = asyncio.create_task(plugin.run())
        try:
            await event_health.wait_state("stale")
            await event_health.wait_state("connected", 2)
        finally:
            await stop(task)
            for w in conns:
                w.close()
            server.close()
        assert event_health.counters["watchdog"] >= 1
        assert event_health.history[:4] == ["connecting", "connected", "stale", "disconnected"]

    asyncio.run(main())


def test_backoff_doubles_to_its_cap_while_the_peer_is_down(event_health):
    async def main() -> None:
        delays: list[float] = []
        enough = asyncio.Event()

        async def sleep(d: float) -> None:
            delays.append(d)
            if len(delays) >= 6:
                enough.set()
            await asyncio.sleep(0)

        port = free_port()  # nobody listens: connection refused
        plugin, _ = make(
            event_health, sleep, transport="tcp", host="127.0.0.1", port=port, backoff_initial=0.5, backoff_max=3.0
        )
        task = asyncio.create_task(plugin.run())
        try:
            await asyncio.wait_for(enough.wait(), TIMEOUT)
        finally:
            await stop(task)
        assert delays[:6] == [0.5, 1.0, 2.0, 3.0, 3.0, 3.0]
        assert event_health.counters["connect_failures"] >= 6
        assert event_health.state in ("disconnected", "connecting")
        assert event_health.snapshot()["ok"] is False  # reconnecting is not ok

    asyncio.run(main())


def test_udp_unicast_datagrams(event_health):
    async def main() -> None:
        port = free_port(socket.SOCK_DGRAM)
        plugin, sink = make(event_health, transport="udp", port=port)
        task = asyncio.create_task(plugin.run())
        try:
            await event_health.wait_state("connected")
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                s.sendto(GGA + b"\r\n" + HDT, ("127.0.0.1", port))  # last line without CR LF
            await sink.wait_raw(2)
            assert event_health.state == "connected" and event_health.snapshot()["ok"] is True
        finally:
            await stop(task)
        assert [r.data for r in sink.raw] == [GGA, HDT]
        assert event_health.counters["lines"] == 2

    asyncio.run(main())


def test_udp_broadcast(event_health):
    async def main() -> None:
        port = free_port(socket.SOCK_DGRAM)
        # the loopback network's broadcast address: no datagram leaves the machine
        plugin, sink = make(event_health, transport="udp", port=port, bind="127.255.255.255", broadcast=True)
        task = asyncio.create_task(plugin.run())
        try:
            await event_health.wait_state("connected")
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
                s.sendto(HDT + b"\r\n", ("127.255.255.255", port))
            await sink.wait_raw(1)
        finally:
            await stop(task)
        assert sink.raw[0].data == HDT

    asyncio.run(main())


def test_udp_watchdog(event_health):
    async def main() -> None:
        plugin, _ = make(event_health, no_wait, transport="udp", port=free_port(socket.SOCK_DGRAM), watchdog=0.1)
        task = asyncio.create_task(plugin.run())
        try:
            await event_health.wait_state("stale")
            await event_health.wait_state("connected", 2)
        finally:
            await stop(task)

    asyncio.run(main())


def test_serial_through_a_pty_and_unplug(event_health):
    async def main() -> None:
        master, slave = os.openpty()
        tty.setraw(master)
        device = os.ttyname(slave)
        plugin, sink = make(event_health, no_wait, transport="serial", device=device, baudrate=38400, backoff_initial=0.05)
        task = asyncio.create_task(plugin.run())
        try:
            await event_health.wait_state("connected")
            os.write(master, GGA + b"\r\n" + HDT + b"\r\n")
            await sink.wait_raw(2)
            os.close(master)  # the adapter is unplugged: the link notices and retries
            master = -1
            await event_health.wait_state("disconnected")
        finally:
            await stop(task)
            os.close(slave)
            if master >= 0:
                os.close(master)
        assert [r.data for r in sink.raw] == [GGA, HDT]
        assert [m.kind for m in sink.measurements] == ["position", "heading"]
        assert event_health.counters["bytes"] == len(GGA) + len(HDT) + 4

    asyncio.run(main())


def test_serial_missing_device_is_a_failed_connect(event_health, tmp_path):
    async def main() -> None:
        failed = asyncio.Event()

        async def sleep(_: float) -> None:
            failed.set()
            await asyncio.sleep(0)

        plugin, _ = make(event_health, sleep, transport="serial", device=str(tmp_path / "ttyUSB9"))
        task = asyncio.create_task(plugin.run())
        try:
            await asyncio.wait_for(failed.wait(), TIMEOUT)
        finally:
            await stop(task)
        assert event_health.counters["connect_failures"] >= 1
        assert "cannot open" in (event_health.last_error or "")

    asyncio.run(main())


def test_file_transport_reads_to_the_end_then_idles(event_health, tmp_path):
    path = tmp_path / "live.nmea"
    path.write_bytes(GGA + b"\n# comment\n" + HDT)  # last line without a line end

    async def main() -> None:
        plugin, sink = make(event_health, transport="file", path=str(path))
        task = asyncio.create_task(plugin.run())
        try:
            await event_health.wait_state("finished")
            assert not task.done()  # run() stays until cancelled
        finally:
            await stop(task)
        assert [r.data for r in sink.raw] == [GGA, HDT]
        assert all(r.t == NOW for r in sink.raw)  # live semantics: the clock's time
        assert event_health.counters["comments"] == 1

    asyncio.run(main())


@pytest.mark.parametrize("garbage", [b"A" * 4096, b"$GPGGA,not,a,sentence*00\r\n" * 100])
def test_bytes_that_bring_no_line_are_as_good_as_silence(event_health, garbage):
    """Issue 32: an endless line counted 5,815 `rejected.too_long` while the input said
    `connected` (ok). Bytes with nothing accepted for `watchdog` seconds now make the
    link `stale` (not ok) and reopen it, like silence; lines accepted keep it up."""
    async def main() -> None:
        conns: list[asyncio.StreamWriter] = []
        stopping = asyncio.Event()

        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            conns.append(writer)
            try:
                while not stopping.is_set():
                    writer.write(garbage)
                    await writer.drain()
                    await asyncio.sleep(0.01)  # the peer's pace, not a wait for an event
            except (ConnectionError, OSError):
                pass

        server = await asyncio.start_server(serve, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        plugin, _ = make(event_health, no_wait, transport="tcp", host="127.0.0.1", port=port, watchdog=0.3)
        task = asyncio.create_task(plugin.run())
        try:
            await event_health.wait_state("stale")
            await event_health.wait_state("connected", 2)  # reopened
        finally:
            stopping.set()
            await stop(task)
            for w in conns:
                w.close()
            server.close()
        c = event_health.counters
        assert c["watchdog"] >= 1 and c.get("accepted", 0) == 0
        assert event_health.history[:4] == ["connecting", "connected", "stale", "disconnected"]

    asyncio.run(main())
