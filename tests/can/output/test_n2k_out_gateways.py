"""The NMEA 2000 output through a gateway (a YDWG-02 in RAW mode, an Actisense NGT-1
over a TCP relay), played by a TCP server on 127.0.0.1 here: what it is sent decodes
(by the `nmea2000` package) to the estimates; a gateway claims no address; a link that
is down counts what it could not send and comes back by itself. And a CAN bus that
cannot be opened is retried, its messages counted `unsent.link_down`."""

from __future__ import annotations

import asyncio
from typing import Any, AsyncIterator

import can
import pytest
from nmea2000 import NMEA2000Decoder, backend

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged_can.formats.actisense_bst import Deframer, unstuff
from edged_can.output.config import Nmea2000OutputConfig
from edged_can.output.plugin import Nmea2000Output

from .conftest import T0, WAIT, fields, man_est, split, stw_est


class Gateway:
    """A TCP server playing the gateway: one connection at a time, every byte kept."""

    def __init__(self) -> None:
        self.connections: asyncio.Queue[tuple[asyncio.StreamReader, asyncio.StreamWriter]] = asyncio.Queue()
        self.server: asyncio.Server | None = None
        self.port = 0

    async def start(self) -> None:
        async def accept(r: asyncio.StreamReader, w: asyncio.StreamWriter) -> None:
            await self.connections.put((r, w))

        self.server = await asyncio.start_server(accept, "127.0.0.1", 0)
        self.port = self.server.sockets[0].getsockname()[1]

    async def accepted(self) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
        return await asyncio.wait_for(self.connections.get(), WAIT)


@pytest.fixture
async def gateway() -> AsyncIterator[Gateway]:
    g = Gateway()
    await g.start()
    yield g
    assert g.server is not None
    g.server.close()


def output(**cfg: Any) -> Nmea2000Output:
    clock = ManualClock(T0)
    health = ComponentHealth("n2k", "output", "nmea2000", clock)
    config = Nmea2000OutputConfig.model_validate({"type": "nmea2000", "backoff_initial": 0.01, **cfg})
    out = Nmea2000Output(config, PluginContext("n2k", clock, health, lambda r: None))
    out.check()
    return out


def write_both(out: Nmea2000Output) -> None:
    out.write([man_est(T0 + 10.0, heading=0.7777)])
    out.write([stw_est(T0 + 10.0, stw=5.55)])  # 128259 and 130577 go with it


async def test_ydwg_raw_lines_decode_to_the_estimates(gateway: Gateway) -> None:
    out = output(transport="ydwg", host="127.0.0.1", port=gateway.port, address=77)
    await out.open()
    try:
        reader, writer = await gateway.accepted()
        await asyncio.wait_for(out.link.connected.wait(), WAIT)
        writer.write(b"12:00:00.000 R 09F11223 00 10 27 FF 7F FF 7F FC\r\n")  # bus traffic: read, dropped
        write_both(out)
        decoder = NMEA2000Decoder(units="si")
        got: dict[int, Any] = {}
        lines: list[bytes] = []
        while len(got) < 6 or fields(got[128259])["speedWaterReferenced"] is None:
            line = await asyncio.wait_for(reader.readline(), WAIT)
            assert line.endswith(b"\r\n")
            lines.append(line)
            msg = decoder.decode(line.decode().strip())
            if msg is not None:
                got[msg.PGN] = msg
        assert abs(fields(got[128259])["speedWaterReferenced"] - 5.55) <= 0.005
        assert abs(fields(got[127250])["heading"] - 0.7777) <= 5e-5
        assert abs(fields(got[130577])["heading"] - 0.7777) <= 5e-5  # fast-packet, 3 lines
        assert sum(1 for ln in lines if split(int(ln[:8], 16))[1] == 130577) == 3  # one message of 3 frames
        assert all(split(int(ln[:8], 16))[2] == 77 for ln in lines)  # the configured address
        assert not any(split(int(ln[:8], 16))[1] in (60928, 59904, 126993) for ln in lines)  # no claim
        assert "address" not in out.ctx.health.info
    finally:
        await out.close()


async def test_a_gateway_that_goes_away_is_counted_and_reconnected(gateway: Gateway) -> None:
    out = output(transport="ydwg", host="127.0.0.1", port=gateway.port)
    await out.open()
    try:
        _, writer = await gateway.accepted()
        await asyncio.wait_for(out.link.connected.wait(), WAIT)
        writer.close()
        await asyncio.wait_for(out.link.down.wait(), WAIT)  # the link notices the close
        out.write([man_est(T0)])
        assert out.ctx.health.counters["unsent.link_down"] == 4  # the PGNs that go with the manoeuvre
        reader, _ = await gateway.accepted()  # it came back by itself
        await asyncio.wait_for(out.link.connected.wait(), WAIT)
        out.write([man_est(T0 + 1.0)])
        assert (await asyncio.wait_for(reader.readline(), WAIT)).strip()
        assert out.ctx.health.counters["disconnects"] == 1 and out.ctx.health.counters["connects"] == 2
    finally:
        await out.close()


async def test_actisense_bst_messages_decode_to_the_estimates(gateway: Gateway) -> None:
    out = output(transport="actisense", host="127.0.0.1", port=gateway.port)
    await out.open()
    try:
        reader, _ = await gateway.accepted()
        await asyncio.wait_for(out.link.connected.wait(), WAIT)
        write_both(out)
        health = ComponentHealth("gw", "input", "gw", ManualClock(T0))
        deframer = Deframer(health)
        got: dict[int, Any] = {}
        while len(got) < 6 or got[128259] is None or fields(got[128259])["speedWaterReferenced"] is None:
            for framed in deframer.feed(await asyncio.wait_for(reader.read(4096), WAIT)):
                bst = unstuff(framed)
                if bst[0] != 0x94:
                    continue  # the start-up commands
                # 94 len prio pgn(3) dst n data ck: a whole message (the NGT-1 cuts it up)
                assert bst[1] == len(bst) - 3 and bst[7] == len(bst) - 9 and sum(bst) & 0xFF == 0
                pgn = int.from_bytes(bst[3:6], "little")
                got[pgn] = backend.decode(pgn, bytes(bst[8:-1]), 0, bst[6], bst[2], "si")
        assert abs(fields(got[128259])["speedWaterReferenced"] - 5.55) <= 0.005
        assert abs(fields(got[130577])["heading"] - 0.7777) <= 5e-5  # 14 bytes in one BST message
    finally:
        await out.close()


async def test_a_bus_that_cannot_be_opened_is_retried_and_counts_what_it_could_not_send() -> None:
    out = output(interface="virtual", channel="n2k-out-never")
    opened = asyncio.Event()

    def failing(**_: Any) -> can.BusABC:
        if out.ctx.health.counters.get("connect_failures", 0) >= 2:
            opened.set()
            return can.Bus(interface="virtual", channel="n2k-out-never")
        raise OSError(19, "No such device")

    out.link.open_bus = failing  # type: ignore[attr-defined]
    await out.open()
    try:
        out.write([man_est(T0)])
        assert out.ctx.health.counters["unsent.link_down"] == 4  # no bus yet
        await asyncio.wait_for(opened.wait(), WAIT)
        await asyncio.wait_for(out.link.connected.wait(), WAIT)
        assert out.ctx.health.counters["connect_failures"] == 2
        assert out.link.send(out.encode("127250")) is True  # type: ignore[arg-type]
    finally:
        await out.close()
