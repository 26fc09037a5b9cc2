"""The simulated vessel in real time, for `edged demo`.

`LiveVessel.run()` simulates a second ahead at a time and sends each record when its
instant comes: CAN frames onto a python-can bus (the in-process `virtual` interface by
default, so the daemon's CAN input reads it like a real bus) and NMEA sentences as UDP
datagrams to 127.0.0.1, where the NMEA input listens. Records are the very ones the
file writer would write for the same seed (the encoders are shared); only their time
base differs: the live clock's start instead of the scenario's fixed epoch.
"""

from __future__ import annotations

import asyncio
import math
import socket
from collections import Counter
from typing import Awaitable, Callable

import can
import numpy as np

from edged.clock import Clock, LiveClock

from .emit import Batch
from .nmea0183 import tag_blocks
from .run import Simulation
from .scenario import Scenario
from .scenarios import SCENARIOS


class LiveVessel:
    """A scenario played in real time onto a CAN bus and an NMEA UDP port."""

    def __init__(
        self,
        scenario: str | Scenario = "manoeuvre-zigzag-north",
        seed: int = 0,
        clock: Clock | None = None,
        sleep: Callable[[float], Awaitable[None]] = asyncio.sleep,
        chunk_s: float = 1.0,
    ) -> None:
        self.scenario = SCENARIOS[scenario] if isinstance(scenario, str) else scenario
        self.seed = seed
        self.clock = clock if clock is not None else LiveClock()
        self.sleep = sleep
        self.chunk_s = chunk_s
        self.sent: Counter = Counter()  #: records sent by bus

    async def run(
        self,
        can_channel: str = "edged-demo",
        nmea_udp_port: int | None = None,
        nmea_host: str = "127.0.0.1",
        duration: float | None = None,
        can_interface: str = "virtual",
        with_tags: bool = False,
    ) -> Counter:
        """Emit until `duration` seconds of simulated time have passed (or cancelled).

        `with_tags` prefixes each sentence with a TAG block of its send time.
        """
        sim = Simulation(self.scenario, self.seed, duration=math.inf if duration is None else duration)
        epoch_us = self.scenario.start_epoch * 1_000_000
        start = self.clock.now()
        bus = can.Bus(interface=can_interface, channel=can_channel)
        udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM) if nmea_udp_port is not None else None
        try:
            while sim.t < sim.duration:
                chunk = sim.advance(min(sim.t + self.chunk_s, sim.duration))
                for t_rel, sends in _schedule(chunk.nmea, chunk.can, epoch_us):
                    wait = start + t_rel - self.clock.now()
                    if wait > 0:
                        await self.sleep(wait)
                    stamp = start + t_rel
                    for bus_name, payload in sends:
                        if bus_name == "can":
                            fid, ext, data = payload
                            bus.send(can.Message(timestamp=stamp, arbitration_id=fid, is_extended_id=ext, data=data))
                        elif udp is not None:
                            line = _tag(stamp) + payload if with_tags and payload.startswith("$") else payload
                            udp.sendto((line + "\r\n").encode("ascii"), (nmea_host, nmea_udp_port))
                        self.sent[bus_name] += 1
        finally:
            bus.shutdown()
            if udp is not None:
                udp.close()
        return self.sent


def _tag(stamp: float) -> str:
    ms = int(round(stamp * 1000))
    return tag_blocks(np.array([ms], dtype=np.int64))[0]


def _schedule(nmea: Batch, frames: Batch, epoch_us: int):
    """(seconds since start, [(bus, payload), ...]) grouped by instant, in time order."""
    merged = sorted(
        [(t, 0, i) for i, t in enumerate(nmea.t_us.tolist())] + [(t, 1, i) for i, t in enumerate(frames.t_us.tolist())]
    )
    group: list = []
    current = None
    for t, which, i in merged:
        if t != current and group:
            yield (current - epoch_us) / 1e6, group
            group = []
        current = t
        group.append(("nmea", nmea.payload[i]) if which == 0 else ("can", frames.payload[i]))
    if group:
        yield (current - epoch_us) / 1e6, group
