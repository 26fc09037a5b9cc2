"""The `n2k_gateway` input on a serial port (a pty pair stands in for the USB serial
of an NGT-1 or an iKonvert) and Actisense BST over TCP: the start-up commands are sent,
messages decode as from a bus, a message cut by a lost link is counted and never
joined to the next one, and reading resumes. Waits are on events with timeouts."""

from __future__ import annotations

import asyncio
import base64
import json
import os
import tty

import pytest
from pydantic import ValidationError

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged_can.gateway import GatewayConfig, GatewayInput
from nmea_rig import NOW, Sink

HDG = bytes.fromhex("ff103bff7fcef5fc")  # 127250: heading 1.5120 rad, true


def _ck(body: bytes) -> bytes:
    return body + bytes([(-sum(body)) & 0xFF])


def bst93(pgn: int, src: int, data: bytes, prio: int = 2) -> bytes:
    """An NGT-1 "N2K message received", framed and stuffed as on the wire."""
    body = bytes([prio]) + pgn.to_bytes(3, "little") + bytes([255, src]) + bytes(4) + bytes([len(data)]) + data
    msg = _ck(bytes([0x93, len(body)]) + body)
    return b"\x10\x02" + msg.replace(b"\x10", b"\x10\x10") + b"\x10\x03"


def _make(sleep, **cfg) -> tuple[GatewayInput, Sink, ComponentHealth]:
    config = GatewayConfig(type="n2k_gateway", **cfg)
    health = ComponentHealth("ngt", "input", "n2k_gateway", ManualClock(NOW))
    sink = Sink()
    ctx = PluginContext(name="ngt", clock=ManualClock(NOW), health=health, publish=sink,
                        decoder=GatewayInput.make_decoder("ngt", config, health))
    return GatewayInput(config, ctx, sleep=sleep), sink, health


async def _no_wait(_: float) -> None:
    await asyncio.sleep(0)


async def _stop(task: asyncio.Task) -> None:
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task


def _pty() -> tuple[int, int, str]:
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def _drain(fd: int) -> bytes:
    os.set_blocking(fd, False)
    out = b""
    try:
        while chunk := os.read(fd, 4096):
            out += chunk
    except BlockingIOError:
        pass
    return out


def test_ngt1_on_a_serial_port_is_told_to_receive_all_and_decodes_like_a_bus():
    from nmea2000 import _canboat as canboat  # a pinned dependency (pyproject.toml): no skip

    async def main() -> None:
        master, slave, device = _pty()
        plugin, sink, health = _make(_no_wait, gateway="actisense_bst", transport="serial", device=device)
        task = asyncio.create_task(plugin.run())
        try:
            os.write(master, bst93(127250, 7, HDG) * 2 + bst93(127250, 0x10, HDG))
            await sink.wait_raw(3)
            sent = _drain(master)
        finally:
            await _stop(task)
            os.close(slave)
            os.close(master)
        # what the daemon wrote at connect: canboat's NGT-1 start-up (its "receive all")
        assert sent == canboat.GatewayCodec("ngt1").open()
        assert all(r.meta == {"format": "actisense_bst"} and r.data.startswith(b"\x10\x02") for r in sink.raw)
        hdg = [m for m in sink.measurements if m.kind == "heading"]
        assert [m.source for m in hdg] == ["ngt.7", "ngt.7", "ngt.16"]
        assert all(m.values["heading"] == pytest.approx(1.512) for m in hdg)
        assert health.counters["bst_messages"] == 3 and health.counters["bytes_sent"] == len(sent)
        # as recorded (the MCAP raw channel's JSON) and read back, the same measurements
        from edged.channels import encode, raw_from_message

        again = []
        decoder = GatewayInput.make_decoder("ngt", None, ComponentHealth("r", "input", "can", ManualClock(NOW)))
        for r in sink.raw:
            ((topic, _, payload),) = encode(r)
            back = raw_from_message(topic, json.loads(json.dumps(payload)))
            assert back == r
            again.extend(decoder.decode(back))
        assert [(m.kind, m.source, m.values) for m in again] == [(m.kind, m.source, m.values) for m in sink.measurements]
        assert GatewayConfig(type="n2k_gateway", gateway="actisense_bst", transport="serial", device=device).baudrate == 115200

    asyncio.run(main())


def test_serial_link_lost_mid_message_counts_it_and_resumes_with_the_next():
    """The watchdog closes a port that fell silent in the middle of a message; the rest
    of that message, arriving after the reopen, is noise, the next message decodes."""

    async def main() -> None:
        master, slave, device = _pty()
        msg = bst93(127250, 7, HDG)
        waits = 0

        async def sleep(_: float) -> None:  # the backoff: the port is closed now
            nonlocal waits
            waits += 1
            if waits == 1:
                os.write(master, msg[9:] + msg)
            await asyncio.sleep(0)

        plugin, sink, health = _make(sleep, gateway="actisense_bst", transport="serial", device=device,
                                     handshake=False, watchdog=0.2)
        task = asyncio.create_task(plugin.run())
        try:
            os.write(master, msg + msg[:9])
            await sink.wait_raw(2)
        finally:
            await _stop(task)
            os.close(slave)
            os.close(master)
        assert [r.data for r in sink.raw] == [msg, msg]
        c = health.counters
        assert c["partial_messages"] == 1 and c["watchdog"] == 1 and c["connects"] == 2
        assert c["discarded_bytes"] == len(msg) - 9  # the cut message's tail, not decoded
        assert [m.kind for m in sink.measurements] == ["heading", "heading"]

    asyncio.run(main())


def test_bst_over_tcp_drops_mid_message_and_comes_back():
    """A PRO-NDC-1E2K or a serial-to-TCP relay of an NGT-1: BST over TCP, no start-up."""

    async def main() -> None:
        msg = bst93(127250, 7, HDG)
        conns: list[int] = []

        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            conns.append(1)
            writer.write(msg + msg[:12] if len(conns) == 1 else msg[12:] + msg)
            await writer.drain()
            writer.close()

        server = await asyncio.start_server(serve, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        plugin, sink, health = _make(_no_wait, gateway="actisense_bst", transport="tcp", host="127.0.0.1", port=port)
        task = asyncio.create_task(plugin.run())
        try:
            await sink.wait_raw(2)
        finally:
            await _stop(task)
            server.close()
        assert [r.data for r in sink.raw[:2]] == [msg, msg]
        c = health.counters
        assert c["partial_messages"] >= 1 and c["connects"] >= 2 and "bytes_sent" not in c
        assert not [k for k in c if k.startswith("rejected.")]

    asyncio.run(main())


def test_ikonvert_on_a_serial_port_is_put_on_the_bus_and_its_lines_decode():
    async def main() -> None:
        master, slave, device = _pty()
        plugin, sink, health = _make(_no_wait, gateway="ikonvert", transport="serial", device=device)
        task = asyncio.create_task(plugin.run())
        line = b"!PDGY,127250,2,7,255,100.5," + base64.b64encode(HDG) + b"\r\n"
        try:
            os.write(master, b"$PDGY,000000,4,0,1,0,0,0\r\n" + line * 2)
            await sink.wait_raw(3)
            sent = _drain(master)
        finally:
            await _stop(task)
            os.close(slave)
            os.close(master)
        assert sent.startswith(b"$PDGY,N2NET_OFFLINE\r\n")  # canboat's iKonvert start-up
        assert [m.source for m in sink.measurements if m.kind == "heading"] == ["ngt.7", "ngt.7"]
        # its status line is recorded (the gateway's own bytes) and counted, not a measurement
        assert sink.raw[0].data.startswith(b"$PDGY,000000") and health.counters["gateway_status"] == 1
        assert GatewayConfig(type="n2k_gateway", gateway="ikonvert", transport="serial", device=device).baudrate == 230400

    asyncio.run(main())


def test_actisense_ascii_over_tcp_decodes():
    async def main() -> None:
        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            writer.write(b"A173321.107 07FF2 1F112 FF103BFF7FCEF5FC\r\n" * 2)
            await writer.drain()
            await reader.read()

        server = await asyncio.start_server(serve, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        plugin, sink, health = _make(_no_wait, gateway="actisense_ascii", transport="tcp", host="127.0.0.1", port=port)
        task = asyncio.create_task(plugin.run())
        try:
            await sink.wait_raw(2)
        finally:
            await _stop(task)
            server.close()
        assert [m.source for m in sink.measurements if m.kind == "heading"] == ["ngt.7", "ngt.7"]
        assert health.counters["lines"] == 2

    asyncio.run(main())


def test_serial_config_errors_name_the_key():
    with pytest.raises(ValidationError, match="device"):
        GatewayConfig(type="n2k_gateway", gateway="actisense_bst", transport="serial")
    with pytest.raises(ValidationError, match="port"):
        GatewayConfig(type="n2k_gateway", gateway="ydwg_raw", transport="udp")
    with pytest.raises(ValidationError, match="handshake"):  # a YDWG has no start-up conversation
        GatewayConfig(type="n2k_gateway", gateway="ydwg_raw", transport="serial", device="/dev/ttyUSB0",
                      handshake=True)
    cfg = GatewayConfig(type="n2k_gateway", gateway="actisense_bst", transport="tcp", host="10.0.0.5", port=50001)
    assert cfg.handshake is False  # a relay in between did the start-up
    cfg = GatewayConfig(type="n2k_gateway", gateway="actisense_bst", transport="serial", device="/dev/ttyUSB0")
    assert cfg.handshake is True and cfg.claims()[0].resource == ("serial", os.path.realpath("/dev/ttyUSB0"))
