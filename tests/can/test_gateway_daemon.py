"""Gateways feeding the daemon itself (Runtime from a configuration file, recording to
MCAP): a Yacht Devices RAW server on 127.0.0.1 that drops its connection in the middle
of a line and comes back, an Actisense N2K ASCII sender over UDP, and an NGT-1 speaking
BST binary through a pty. Measurements resume after the drop, the cut line is counted,
nothing crashes, and the recording replays to the same measurements."""

from __future__ import annotations

import asyncio
import os
import socket
import tty
from pathlib import Path
from typing import Any, Callable

from core_dummies import ListOutput

from edged.cli import build_parser
from edged.clock import LiveClock
from edged.commands import dispatch
from edged.config import load_config
from edged.records import Measurement
from edged.registry import Registry
from edged.runtime import Runtime

SAFETY = 30.0
# 127250 from 0x13, 1.4870 rad magnetic (merrimac-ydwg-2020.raw's first heading line)
YD = b"00:29:58.627 R 09F11213 00 16 3A FF 7F FF 7F FD"
ASCII = b"A173321.107 07FF2 1F112 FF103BFF7FCEF5FC"  # 127250 from 7, 1.5120 rad true
HDG = bytes.fromhex("ff103bff7fcef5fc")


def _bst93(src: int) -> bytes:
    body = bytes([2]) + (127250).to_bytes(3, "little") + bytes([255, src]) + bytes(4) + bytes([8]) + HDG
    msg = bytes([0x93, len(body)]) + body
    msg += bytes([(-sum(msg)) & 0xFF])
    return b"\x10\x02" + msg.replace(b"\x10", b"\x10\x10") + b"\x10\x03"


class WatchOutput(ListOutput):
    """ListOutput that wakes the test when its records satisfy `until`."""

    until: Callable[[list[Any]], bool] = staticmethod(lambda records: False)
    done: asyncio.Event

    def write(self, batch: list[Any]) -> None:
        super().write(batch)
        if type(self).until(self.records):
            type(self).done.set()


def _heading_sources(records: list[Any]) -> dict[str, int]:
    out: dict[str, int] = {}
    for r in records:
        if isinstance(r, Measurement) and r.kind.startswith("heading"):
            out[r.source] = out.get(r.source, 0) + 1
    return out


def test_three_gateways_feed_the_daemon_drop_and_resume(tmp_path: Path) -> None:
    recording = tmp_path / "gw.mcap"

    async def main() -> tuple[dict[str, int], dict[str, Any]]:
        conns: list[int] = []

        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            conns.append(1)
            if len(conns) == 1:
                writer.write((YD + b"\r\n") * 3 + YD[:25])  # then the gateway goes away
                await writer.drain()
                writer.close()
                return
            writer.write(YD[25:] + b"\r\n" + (YD + b"\r\n") * 3)  # the tail alone is no line
            await writer.drain()
            await reader.read()

        server = await asyncio.start_server(serve, "127.0.0.1", 0)
        tcp_port = server.sockets[0].getsockname()[1]
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.bind(("127.0.0.1", 0))
            udp_port = s.getsockname()[1]
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        cfg = tmp_path / "edged.toml"
        cfg.write_text(f"""
[inputs.ydwg]
type = "n2k_gateway"
gateway = "ydwg_raw"
transport = "tcp"
host = "127.0.0.1"
port = {tcp_port}
backoff_initial = 0.01

[inputs.ngx]
type = "n2k_gateway"
gateway = "actisense_ascii"
transport = "udp"
port = {udp_port}

[inputs.ngt1]
type = "n2k_gateway"
gateway = "actisense_bst"
transport = "serial"
device = "{os.ttyname(slave)}"

[outputs.watch]
type = "watch"

[outputs.mcap]
type = "mcap"
path = "{recording}"
""")
        registry = Registry()
        registry.register("outputs", "watch", WatchOutput)
        ListOutput.instances = []
        WatchOutput.done = asyncio.Event()
        want = {"ydwg.19": 6, "ngx.7": 2, "ngt1.7": 2}
        WatchOutput.until = staticmethod(
            lambda records: all(_heading_sources(records).get(k, 0) >= n for k, n in want.items())
        )
        rt = Runtime(load_config(cfg, registry), registry, LiveClock())
        await rt.start()
        try:
            loop = asyncio.get_running_loop()
            udp, _ = await loop.create_datagram_endpoint(asyncio.DatagramProtocol, remote_addr=("127.0.0.1", udp_port))
            os.write(master, _bst93(7) * 2)
            end = loop.time() + SAFETY
            while not WatchOutput.done.is_set():  # UDP: until the listener is up
                assert loop.time() < end, _heading_sources(ListOutput.instances[0].records)
                udp.sendto(ASCII + b"\r\n")
                try:
                    await asyncio.wait_for(WatchOutput.done.wait(), 0.05)
                except asyncio.TimeoutError:
                    pass
            udp.close()
            snap = rt.health_snapshot()
        finally:
            await rt.stop()
            server.close()
            os.close(slave)
            os.close(master)
        return _heading_sources(ListOutput.instances[0].records), snap

    live, snap = asyncio.run(main())
    assert live["ydwg.19"] == 6 and live["ngt1.7"] == 2 and live["ngx.7"] >= 2
    yd = snap["inputs"]["ydwg"]
    assert yd["counters"]["partial_lines"] == 1 and yd["counters"]["rejected.bad_line"] == 1
    assert yd["counters"]["connects"] >= 2
    assert snap["inputs"]["ngt1"]["counters"]["bytes_sent"] > 0  # the NGT-1 was told to send all

    # the recording replays through the same decoders to the same measurements
    ListOutput.instances = []
    replay_cfg = tmp_path / "replay.toml"
    replay_cfg.write_text('[outputs.watch]\ntype = "watch"\n')
    registry = Registry()
    registry.register("outputs", "watch", WatchOutput)
    args = build_parser().parse_args(["replay", str(recording), "-c", str(replay_cfg), "--no-zenoh", "--no-progress"])
    assert dispatch(args, registry) == 0
    assert _heading_sources(ListOutput.instances[0].records) == live

