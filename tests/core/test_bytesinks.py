"""The byte links of the text bridge outputs (edged.bytesinks): each delivers,
none blocks or raises for a dead or slow peer, and what cannot go is counted."""

from __future__ import annotations

import asyncio
import os
import socket
import tty

import pytest
from pydantic import ValidationError

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.bytesinks import TcpServerSink, TransportSettings, make_sink, write_bounded
from waiting import wait_for

WAIT = 10.0


def health() -> ComponentHealth:
    return ComponentHealth("out", "output", "test", ManualClock(0.0))


def settings(**kw) -> TransportSettings:
    return TransportSettings(**kw)


async def test_udp_sends_each_message_as_one_datagram() -> None:
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.setblocking(False)
    h = health()
    sink = make_sink(settings(transport="udp", port=rx.getsockname()[1]), h)
    assert sink.send(b"early\r\n") is False  # before the link is up: counted, not raised
    assert h.counters["unsent.link_down"] == 1
    await sink.open()
    await wait_for(lambda: sink.up, WAIT)
    assert sink.send(b"$EDHDT,1.0,T*00\r\n") is True
    loop = asyncio.get_running_loop()
    data = await asyncio.wait_for(loop.sock_recv(rx, 2048), WAIT)
    assert data == b"$EDHDT,1.0,T*00\r\n"
    await sink.close()
    rx.close()


async def _client(port: int) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    return await asyncio.open_connection("127.0.0.1", port)


async def test_tcp_server_sends_to_every_client_and_refuses_one_too_many() -> None:
    h = health()
    sink = make_sink(settings(transport="tcp", port=0, max_clients=2), h)
    assert isinstance(sink, TcpServerSink)
    await sink.open()
    await asyncio.wait_for(sink.listening.wait(), WAIT)
    port = sink.bound_port
    assert port
    a, b = await _client(port), await _client(port)
    await wait_for(lambda: sink.status()["clients"] == 2, WAIT)
    c = await _client(port)
    assert await asyncio.wait_for(c[0].read(), WAIT) == b""  # closed at once
    assert h.counters["rejected.too_many_clients"] == 1
    sink.send(b"line\r\n")
    for r, _ in (a, b):
        assert await asyncio.wait_for(r.readexactly(6), WAIT) == b"line\r\n"
    a[1].close()  # one leaves: the other still gets everything
    await wait_for(lambda: sink.status()["clients"] == 1, WAIT)
    sink.send(b"next\r\n")
    assert await asyncio.wait_for(b[0].readexactly(6), WAIT) == b"next\r\n"
    await sink.close()
    b[1].close()


async def test_a_client_that_does_not_read_loses_messages_and_slows_nobody() -> None:
    h = health()
    sink = make_sink(settings(transport="tcp", port=0, client_buffer=1024), h)
    await sink.open()
    await asyncio.wait_for(sink.listening.wait(), WAIT)
    slow = socket.create_connection(("127.0.0.1", sink.bound_port))
    slow.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    await wait_for(lambda: sink.status()["clients"] == 1, WAIT)
    chunk = b"x" * 65000 + b"\r\n"
    for _ in range(400):  # 26 MB: more than any kernel buffers for one socket
        assert sink.send(chunk)  # the server sent it: only that client misses some
    assert h.counters["dropped.slow_client"] > 0
    slow.close()
    await sink.close()


async def test_serial_writes_to_the_port() -> None:
    master, slave = os.openpty()
    tty.setraw(master)
    h = health()
    sink = make_sink(settings(transport="serial", device=os.ttyname(slave), baudrate=38400), h)
    await sink.open()
    await wait_for(lambda: sink.up, WAIT)
    sink.send(b"$EDROT,-25.9,A*00\r\n")
    loop = asyncio.get_running_loop()
    got = b""
    while not got.endswith(b"\r\n"):
        got += await asyncio.wait_for(loop.run_in_executor(None, os.read, master, 256), WAIT)
    assert got == b"$EDROT,-25.9,A*00\r\n"
    await sink.close()
    os.close(master)
    os.close(slave)


async def test_a_port_that_cannot_be_opened_is_retried_and_counted_never_raised() -> None:
    h = health()
    sink = make_sink(settings(transport="serial", device="/dev/edged-no-such-port", backoff_initial=0.01), h)
    await sink.open()
    await wait_for(lambda: h.counters.get("connect_failures", 0) >= 2, WAIT)
    assert sink.send(b"x\r\n") is False
    assert h.counters["unsent.link_down"] == 1 and "cannot open" in (h.last_error or "")
    await sink.close()


async def test_a_tcp_port_in_use_is_retried_and_counted() -> None:
    busy = socket.socket()
    busy.bind(("127.0.0.1", 0))
    busy.listen()
    h = health()
    sink = make_sink(settings(transport="tcp", port=busy.getsockname()[1], backoff_initial=0.01), h)
    await sink.open()
    await wait_for(lambda: h.counters.get("connect_failures", 0) >= 1, WAIT)
    assert h.info["link"] in ("disconnected", "connecting")
    assert sink.send(b"x\r\n") is False and h.counters["unsent.link_down"] == 1
    await sink.close()
    busy.close()


@pytest.mark.parametrize("kw, words", [
    ({"transport": "serial"}, "needs a device"),
    ({"transport": "smoke"}, "'udp', 'tcp' or 'serial'"),
    ({"port": 70000}, "less than or equal to 65535"),
    ({"transport": "udp", "port": 0}, "port 0 is none"),
    ({"max_clients": 0}, "greater than or equal to 1"),
    ({"client_buffer": 10}, "greater than or equal to 1024"),
])
def test_bad_transport_settings_are_refused(kw: dict, words: str) -> None:
    with pytest.raises(ValidationError, match=words):
        TransportSettings(**kw)


async def test_udp_broadcast_is_allowed_only_when_configured() -> None:
    """A broadcast address (192.168.1.255) needs SO_BROADCAST, or every send fails."""
    for broadcast in (True, False):
        h = health()
        sink = make_sink(settings(transport="udp", port=9, broadcast=broadcast), h)
        await sink.open()
        await wait_for(lambda: sink.up, WAIT)
        sock = sink._transport.get_extra_info("socket")  # type: ignore[attr-defined]
        assert bool(sock.getsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST)) is broadcast
        await sink.close()


class _Transport:
    def __init__(self, waiting: int = 0, closing: bool = False, fails: bool = False) -> None:
        self.waiting, self.closing, self.fails, self.written = waiting, closing, fails, b""

    def is_closing(self) -> bool:
        return self.closing

    def get_write_buffer_size(self) -> int:
        return self.waiting

    def write(self, data: bytes) -> None:
        if self.fails:
            raise OSError(5, "Input/output error")
        self.written += data

    sendto = write


class _Writer:
    def __init__(self, transport: _Transport) -> None:
        self.transport = transport

    def write(self, data: bytes) -> None:
        self.transport.write(data)


@pytest.mark.parametrize("transport, counter", [
    (None, "unsent.link_down"),  # not open
    (_Transport(closing=True), "unsent.link_down"),
    (_Transport(waiting=1000), "dropped.slow_link"),  # a peer slower than the messages
    (_Transport(fails=True), "errors.send"),  # an adapter unplugged mid-write
])
def test_a_bounded_write_that_cannot_go_is_counted_never_raised(transport, counter) -> None:
    h = health()
    w = None if transport is None else _Writer(transport)
    assert write_bounded(w, b"x" * 100, 1024, h, "serial /dev/x", "dropped.slow_link") is False
    assert {k: v for k, v in h.counters.items() if k != "errors"} == {counter: 1}  # (errors: the logged ones)
    ok = _Writer(_Transport(waiting=900))
    assert write_bounded(ok, b"x" * 100, 1024, h, "serial /dev/x") is True and ok.transport.written == b"x" * 100


def test_a_udp_send_the_kernel_refuses_is_counted() -> None:
    h = health()
    sink = make_sink(settings(transport="udp", port=9), h)
    sink._transport = _Transport(fails=True)  # type: ignore[attr-defined,assignment]
    assert sink.send(b"x") is False
    assert h.counters["errors.send"] == 1 and "udp send" in (h.last_error or "")
