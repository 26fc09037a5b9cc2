"""No loops (issue 35): edged's NMEA 0183 output looped into its own NMEA 0183 input
(one UDP port, as on a ship's LAN where a multiplexer echoes everything) gives no
measurement: the input counts `rejected.own_output`, while another talker's sentence
on the same port is read."""

from __future__ import annotations

import socket

from bridge_rig import T0, draft, manoeuvre, stw
from core_dummies import ListOutput
from waiting import wait_for

from edged.clock import ManualClock
from edged.config import parse_config
from edged.records import Measurement
from edged.registry import Registry
from edged.runtime import Runtime
from edged_nmea0183.encode import sentence


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


async def test_the_outputs_sentences_looped_into_an_input_make_no_measurement() -> None:
    port = _free_udp_port()
    registry = Registry()
    registry.register("outputs", "list", ListOutput)
    ListOutput.instances = []
    cfg = parse_config({
        "inputs": {"bridge": {"type": "nmea0183", "transport": "udp", "port": port}},
        "outputs": {"nmea": {"type": "nmea0183", "transport": "udp", "port": port, "rates": {"HDT": 100}},
                    "seen": {"type": "list"}},
    }, registry)
    rt = Runtime(cfg, registry, ManualClock(T0))
    await rt.start()
    try:
        nmea = next(o for o in rt.outputs if o.name == "nmea")
        inp = next(i for i in rt.inputs if i.name == "bridge")
        await wait_for(lambda: nmea.plugin.plugin.linked() and inp.health.state == "connected")
        for k in range(10):
            for e in (manoeuvre(T0 + k), stw(T0 + k), draft(T0 + k)):
                rt.router.publish(e)
        await wait_for(lambda: inp.health.counters.get("rejected.own_output", 0) >= 10 * 5)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:  # a real gyro's sentence
            s.sendto(sentence("HE", "HDT", ("123.4", "T")), ("127.0.0.1", port))
        seen = ListOutput.instances[0]
        await wait_for(timeout=10, cond=lambda: any(isinstance(r, Measurement) for r in seen.records))
        measured = [r for r in seen.records if isinstance(r, Measurement)]
        assert [(m.kind, m.source) for m in measured] == [("heading", "bridge")]
        assert inp.health.counters["accepted"] == inp.health.counters["rejected.own_output"] + 1
        assert nmea.health.counters["sent"] >= 10 * 5
    finally:
        await rt.stop()
