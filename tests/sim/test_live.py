"""LiveVessel plays a scenario onto a virtual CAN bus and an NMEA UDP port, paced by
the injected clock (a fake sleep advances a ManualClock: no real waiting)."""

from __future__ import annotations

import asyncio
import socket

import can
import pynmea2

from edged.clock import ManualClock
from edged_sim.live import LiveVessel


def test_live_vessel_emits_frames_and_sentences_in_time() -> None:
    clock = ManualClock(1_800_000_000.0)
    waits: list[float] = []

    async def fake_sleep(dt: float) -> None:
        waits.append(dt)
        clock.step(dt)

    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    udp.bind(("127.0.0.1", 0))
    udp.setblocking(False)
    listener = can.Bus(interface="virtual", channel="sim-live-test")
    try:
        vessel = LiveVessel("manoeuvre-zigzag-north", seed=2, clock=clock, sleep=fake_sleep)
        sent = asyncio.run(vessel.run(can_channel="sim-live-test", nmea_udp_port=udp.getsockname()[1], duration=2.0))
        frames = []
        while (msg := listener.recv(timeout=0)) is not None:
            frames.append(msg)
        lines = []
        while True:
            try:
                lines.append(udp.recv(4096).decode("ascii"))
            except BlockingIOError:
                break
    finally:
        listener.shutdown()
        udp.close()
    assert sent["can"] == len(frames) and sent["nmea"] == len(lines) > 0
    assert all(pynmea2.parse(line.strip(), check=True) for line in lines)
    assert {f.arbitration_id for f in frames} >= {0x320, 0x321, 0x09F11212}
    # Paced by the injected clock: 2 s of data took 2 s of (fake) time, never waiting backwards.
    assert abs(clock.now() - 1_800_000_002.0) < 0.05 and all(w > 0 for w in waits)
