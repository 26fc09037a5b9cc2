"""The `n2k_gateway` input, live: a test gateway on 127.0.0.1 (a TCP server and a UDP
sender written here) feeds it; the connection drops in the middle of a line and comes
back. Every wait is on an event with a timeout, never a sleep-poll."""

from __future__ import annotations

import asyncio
import socket
from functools import reduce

import pytest
from pydantic import ValidationError

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged_can.gateway import GatewayConfig, GatewayInput
from nmea_rig import NOW, Sink

HDG = b"2024-01-01T12:00:00.000Z,2,127250,7,255,8,ff,10,3b,ff,7f,ce,f5,fc"  # 1.5120 rad, true


def _pcdin() -> bytes:
    body = "PCDIN,01F119,00000000,0F,2AAF00D1067414FF"
    return f"${body}*{reduce(lambda a, ch: a ^ ord(ch), body, 0):02X}".encode()


async def _no_wait(_: float) -> None:
    await asyncio.sleep(0)


def _make(**cfg) -> tuple[GatewayInput, Sink, ComponentHealth]:
    config = GatewayConfig(type="n2k_gateway", **cfg)
    health = ComponentHealth("ydwg", "input", "n2k_gateway", ManualClock(NOW))
    sink = Sink()
    ctx = PluginContext(name="ydwg", clock=ManualClock(NOW), health=health, publish=sink,
                        decoder=GatewayInput.make_decoder("ydwg", config, health))
    return GatewayInput(config, ctx, sleep=_no_wait), sink, health


async def _stop(task: asyncio.Task) -> None:
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task


def test_tcp_gateway_drops_mid_line_and_comes_back():
    async def main() -> None:
        conns: list[int] = []

        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            conns.append(1)
            if len(conns) == 1:
                writer.write(HDG + b"\r\n" + HDG + b"\r\n" + HDG[:20])  # then the gateway goes away
            else:
                writer.write(HDG[20:] + b"\r\n" + HDG + b"\r\n")  # the tail alone is not a line
            await writer.drain()
            writer.close()

        server = await asyncio.start_server(serve, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        plugin, sink, health = _make(gateway="actisense_plain", transport="tcp", host="127.0.0.1", port=port)
        task = asyncio.create_task(plugin.run())
        try:
            await sink.wait_raw(4)
        finally:
            await _stop(task)
            server.close()
        raw = sink.raw
        assert [r.data for r in raw[:2]] + [raw[3].data] == [HDG, HDG, HDG]
        assert all(r.protocol == "can" and r.meta == {"format": "actisense_plain"} and r.t == NOW for r in raw)
        hdg = [m for m in sink.measurements if m.kind == "heading"]
        assert len(hdg) == 3 and all(m.source == "ydwg.7" and m.values["heading"] == pytest.approx(1.512) for m in hdg)
        c = health.counters
        assert c["partial_lines"] == 1  # the cut line, counted, never joined to the next
        assert c["rejected.bad_line"] == 1  # its tail on the next connection
        assert c["connects"] >= 2 and c["disconnects"] >= 1

    asyncio.run(main())


def test_udp_gateway_datagrams_decode():
    async def main() -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        plugin, sink, health = _make(gateway="pcdin", transport="udp", port=port)
        task = asyncio.create_task(plugin.run())
        try:
            loop = asyncio.get_running_loop()
            transport, _ = await loop.create_datagram_endpoint(asyncio.DatagramProtocol, remote_addr=("127.0.0.1", port))
            for _ in range(200):  # until the listener is up: each send is one datagram of two lines
                transport.sendto(_pcdin() + b"\r\n" + _pcdin())
                try:
                    await asyncio.wait_for(sink.wait_raw(2), 0.05)
                    break
                except asyncio.TimeoutError:
                    continue
            transport.close()
        finally:
            await _stop(task)
        att = [m for m in sink.measurements if m.kind == "attitude"]
        assert att and att[0].source == "ydwg.15" and att[0].values["roll"] == pytest.approx(0.5236)
        assert health.counters["lines"] == len(sink.raw)

    asyncio.run(main())


def test_config_errors_name_the_key():
    with pytest.raises(ValidationError, match="host"):
        GatewayConfig(type="n2k_gateway", gateway="ydwg_raw", transport="tcp", port=1457)
    with pytest.raises(ValidationError, match="gateway"):
        GatewayConfig(type="n2k_gateway", gateway="nmea0183", transport="udp", port=1457)
    assert GatewayConfig(type="n2k_gateway", gateway="ydwg_raw", transport="udp", port=1456).claims()


def test_ydwg_raw_over_tcp_decodes_like_its_log():
    """A YDWG-02's RAW stream (time of day in each line; live, the clock stamps it)."""
    # From merrimac-ydwg-2020.raw: 09F11213 = priority 2, PGN 127250 (0x1F112), source 0x13.
    line = b"00:29:58.627 R 09F11213 00 16 3A FF 7F FF 7F FD"

    async def main() -> None:
        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            writer.write((line + b"\r\n") * 2 + line.replace(b" R ", b" T ") + b"\r\n")  # one it sent itself
            await writer.drain()
            await reader.read()  # keep the connection until the test ends

        server = await asyncio.start_server(serve, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        plugin, sink, health = _make(gateway="ydwg_raw", transport="tcp", host="127.0.0.1", port=port)
        task = asyncio.create_task(plugin.run())
        try:
            await sink.wait_raw(3)
        finally:
            await _stop(task)
            server.close()
        hdg = [m for m in sink.measurements if m.kind == "heading_magnetic"]
        # Bytes 1-2: 0x3A16 = 14870 → 1.4870 rad; the last byte 0xFD & 3 = 1: magnetic (and
        # no variation heard yet, so it stays a magnetic heading).
        assert len(hdg) == 3 and hdg[0].source == "ydwg.19" and hdg[0].values["heading"] == pytest.approx(1.487)
        assert health.counters["frames.tx"] == 1  # live as in a log
        assert all(m.t == NOW for m in hdg)

    asyncio.run(main())


def test_live_pcdin_with_a_wrong_checksum_is_rejected():
    from edged_can.formats import Bad, pcdin

    good = _pcdin()
    assert pcdin.frame(good)
    with pytest.raises(Bad) as bad:
        pcdin.frame(good[:-2] + b"00")
    assert bad.value.reason == "checksum"


def test_an_over_long_line_is_dropped_to_its_end():
    from edged_can.gateway import _Lines

    health = ComponentHealth("g", "input", "n2k_gateway", ManualClock(NOW))
    lines = _Lines(health, 80)  # HDG (68 bytes) fits, 100 bytes do not
    assert lines.feed(b"X" * 100) == []
    assert lines.feed(b"junk,tail-of-long-line\n" + HDG + b"\n") == [HDG]
    assert health.counters["rejected.too_long"] == 1


class _StaleHealth(ComponentHealth):
    """Health whose first `stale` can be awaited (no sleep-polling)."""

    __slots__ = ("stale", "history")

    def __init__(self) -> None:
        super().__init__("ydwg", "input", "n2k_gateway", ManualClock(NOW))
        self.stale = asyncio.Event()
        self.history: list[str] = []

    def set_state(self, state: str, reason: str | None = None) -> None:
        super().set_state(state, reason)
        self.history.append(state)
        if state == "stale":
            self.stale.set()


@pytest.mark.parametrize("garbage", [b"A" * 4096, b"not a gateway line at all\r\n" * 100])
def test_bytes_that_bring_no_message_are_as_good_as_silence(garbage):
    """Issue 32: garbage to an n2k_gateway over TCP left it `connected` and ok while it
    rejected everything. Bytes with no message for `watchdog` seconds now make the link
    `stale` (not ok) and reopen it, like silence."""
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
        config = GatewayConfig(type="n2k_gateway", gateway="actisense_plain", transport="tcp", host="127.0.0.1",
                               port=port, watchdog=0.3)
        health = _StaleHealth()
        sink = Sink()
        ctx = PluginContext(name="ydwg", clock=ManualClock(NOW), health=health, publish=sink,
                            decoder=GatewayInput.make_decoder("ydwg", config, health))
        task = asyncio.create_task(GatewayInput(config, ctx, sleep=_no_wait).run())
        try:
            await asyncio.wait_for(health.stale.wait(), 10)
        finally:
            stopping.set()
            await _stop(task)
            for w in conns:
                w.close()
            server.close()
        assert health.counters["watchdog"] >= 1 and health.counters.get("frames", 0) == 0 and not sink.measurements
        assert health.history[:3] == ["connecting", "connected", "stale"]

    asyncio.run(main())
