"""Replay equals live for chained estimators (DESIGN §2), through a real input.

Live: NMEA 0183 rate-of-turn sentences arrive over TCP into the daemon's real input,
a `sum` estimator consumes the yaw rate, a `chain` estimator consumes both the yaw
rate and the `sum` estimate, and everything is recorded to MCAP. Replay: that
recording runs through the same configuration. The chained estimator's outputs must
be the same, bit for bit, in both and with the upstream estimator in either placement.
"""

from __future__ import annotations

import asyncio
import functools
import operator
from pathlib import Path

import pytest
from core_dummies import ChainEstimator, ListOutput, SumEstimator

from edged.cli import build_parser
from edged.clock import LiveClock
from edged.commands import dispatch
from edged.config import load_config
from edged.records import Estimate
from edged.registry import Registry
from edged.runtime import Runtime

N = 120
SAFETY = 60.0


def _rot(rate_deg_min: float) -> bytes:
    body = f"HEROT,{rate_deg_min:.1f},A"
    cs = functools.reduce(operator.xor, body.encode(), 0)
    return f"${body}*{cs:02X}\r\n".encode()


def _registry() -> Registry:
    r = Registry()
    r.register("estimators", "sum", SumEstimator)
    r.register("estimators", "chain", ChainEstimator)
    r.register("outputs", "list", ListOutput)
    return r


def _config(tmp_path: Path, port: int, placement: str, record: Path | None) -> Path:
    text = f"""
[inputs.gyro]
type = "nmea0183"
transport = "tcp"
host = "127.0.0.1"
port = {port}

[estimators.sum]
type = "sum"
worker = "{placement}"

[estimators.chain]
type = "chain"
upstream = "sum"

[outputs.rec]
type = "list"
"""
    if record is not None:
        text += f'\n[outputs.mcap]\ntype = "mcap"\npath = "{record}"\n'
    p = tmp_path / f"edged-{'live' if record else 'replay'}.toml"
    p.write_text(text)
    return p


def _chain(records: list) -> list[tuple[float, dict]]:
    return [(r.t, r.values) for r in records if isinstance(r, Estimate) and r.name == "chain"]


async def _live(tmp_path: Path, placement: str, recording: Path) -> tuple[list, Path]:
    sent = asyncio.Event()

    async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        for i in range(N):
            writer.write(_rot(float((i * 37) % 200 - 100)))
            if i % 10 == 9:
                await writer.drain()
        await writer.drain()
        sent.set()
        await asyncio.Event().wait()  # keep the link open until the daemon stops

    server = await asyncio.start_server(serve, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    cfg_path = _config(tmp_path, port, placement, recording)
    registry = _registry()
    ListOutput.instances = []
    rt = Runtime(load_config(cfg_path, registry), registry, LiveClock())
    out = ListOutput.instances[0]
    await rt.start()
    loop = asyncio.get_running_loop()
    end = loop.time() + SAFETY
    while len(_chain(out.records)) < 2 * N:  # one per yaw rate and one per sum estimate
        assert loop.time() < end, "the live chain did not produce its estimates"
        await asyncio.sleep(0.005)
    await rt.stop()
    server.close()
    return _chain(out.records), cfg_path


@pytest.mark.parametrize("placement", ["loop", "process"])
def test_chained_estimates_live_equal_replay_of_the_recording(tmp_path: Path, placement: str) -> None:
    recording = tmp_path / "live.mcap"
    live, _ = asyncio.run(_live(tmp_path, placement, recording))
    assert len(live) == 2 * N
    assert live[-1][1]["trace"] == "ye" * 8  # a measurement, then its upstream estimate

    replay_cfg = _config(tmp_path, 1, placement, None)
    registry = _registry()
    for speed in ("0", "200"):
        ListOutput.instances = []
        args = build_parser().parse_args(
            ["replay", str(recording), "-c", str(replay_cfg), "--no-zenoh", "--no-progress", "--speed", speed]
        )
        assert dispatch(args, registry) == 0
        replayed = _chain(ListOutput.instances[0].records)
        assert replayed == live  # the same times and values, bit for bit, in the same order
