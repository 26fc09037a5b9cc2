"""No loops on the bus (issue 35): the daemon's CAN input and its NMEA 2000 output on
one bus (a python-can `virtual` channel). The input's decoder learns from the
output's address claim which address is edged's own and refuses its frames
(`rejected.own_output`): no measurement is made of edged's own estimates, while
another node's heading on the same bus is read."""

from __future__ import annotations

import uuid

import can
from bridge_rig import T0, manoeuvre, stw
from core_dummies import ListOutput
from waiting import wait_for

from edged.clock import ManualClock
from edged.config import parse_config
from edged.records import Measurement
from edged.registry import Registry
from edged.runtime import Runtime
from edged_can.formats import can_id

WAIT = 20.0


async def test_the_outputs_frames_on_the_inputs_bus_make_no_measurement() -> None:
    channel = f"loop-{uuid.uuid4().hex}"
    registry = Registry()
    registry.register("outputs", "list", ListOutput)
    ListOutput.instances = []
    cfg = parse_config({
        "inputs": {"bus": {"type": "can", "interface": "virtual", "channel": channel}},
        "outputs": {"n2k": {"type": "nmea2000", "interface": "virtual", "channel": channel},
                    "seen": {"type": "list"}},
    }, registry)
    clock = ManualClock(T0)
    rt = Runtime(cfg, registry, clock)
    await rt.start()
    try:
        n2k = next(o for o in rt.outputs if o.name == "n2k")
        inp = next(i for i in rt.inputs if i.name == "bus")
        out = n2k.plugin.plugin
        await wait_for(lambda: out.link.connected.is_set() and inp.health.state == "connected", WAIT)

        def claimed() -> bool:  # the claim runs on the clock: move it on as we look
            clock.step(0.05)
            return out.ctx.health.info.get("address") is not None

        await wait_for(claimed, WAIT)
        for k in range(5):
            rt.router.publish(manoeuvre(T0 + 10 + k))
            rt.router.publish(stw(T0 + 10 + k))
        await wait_for(lambda: out.ctx.health.counters.get("sent", 0) >= 5 * 6, WAIT)
        await wait_for(lambda: inp.health.counters.get("rejected.own_output", 0) >= 5 * 6, WAIT)
        other = can.Bus(interface="virtual", channel=channel)  # a gyro at address 18
        try:
            other.send(can.Message(arbitration_id=can_id(2, 127250, 18, 255),
                                   data=bytes([0, 0x10, 0x27, 0xFF, 0x7F, 0xFF, 0x7F, 0xFC]), is_extended_id=True))
        finally:
            other.shutdown()
        seen = ListOutput.instances[0]
        await wait_for(lambda: any(isinstance(r, Measurement) for r in seen.records), WAIT)
        measured = {(r.kind, r.source) for r in seen.records if isinstance(r, Measurement)}
        assert {kind for kind, _ in measured} == {"heading"} and len(measured) == 1
    finally:
        await rt.stop()
