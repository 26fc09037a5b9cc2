"""A real signalk-server reads the Signal K output (issue 35): its "Signal K" data
connection over TCP to the output's server, and its REST API then shows edged's STW
and current, with edged as their source; a stale estimate then shows as null.

Skipped where node is absent or signalk-server is not installed (`make
signalk-server` installs it with npm; `make test` does so first)."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from bridge_rig import T0, Ctx, manoeuvre, stw
from edged_signalk.config import SignalKOutputConfig
from edged_signalk.delta import iso_ms
from edged_signalk.output import SignalKOutput
from signalk_server import SignalKServer, skip_reason
from waiting import wait_for

#: signalk-server starts in about 2 s here; its TCP connection retries within 5 s.
START = 20.0
API = "/signalk/v1/api/vessels/self"

WHY_NOT = skip_reason()
pytestmark = pytest.mark.skipif(WHY_NOT is not None, reason=WHY_NOT or "")


async def test_signalk_server_shows_edgeds_stw_and_current_with_edged_as_the_source(tmp_path: Path) -> None:
    c = Ctx("sk_bridge", "signalk")
    out = SignalKOutput(SignalKOutputConfig(type="signalk", transport="tcp", host="127.0.0.1", port=0), c.ctx)
    out.check()
    await out.open()
    try:
        sink = out.sink
        await asyncio.wait_for(sink.listening.wait(), 5.0)  # type: ignore[union-attr]
        async with SignalKServer(tmp_path / "signalk", "127.0.0.1", sink.bound_port) as server:  # type: ignore[union-attr]
            await wait_for(lambda: out.status().get("clients") == 1, START)  # its data connection is up
            e = stw(T0)
            out.write([e, manoeuvre(T0)])

            speed = await server.poll(f"{API}/navigation/speedThroughWater",
                                      lambda b: b.get("value") == e.values["stw"], START)
            assert speed["$source"] == "edged.sk_bridge"
            assert speed["timestamp"] == iso_ms(T0)

            current = await server.poll(f"{API}/environment/current", lambda b: b.get("value") is not None, START)
            assert current["value"] == {"setTrue": e.values["current_set"], "drift": e.values["current"]}
            assert current["$source"] == "edged.sk_bridge"

            heading = await server.poll(f"{API}/navigation/headingTrue", lambda b: "value" in b, START)
            assert heading["value"] == manoeuvre().values["heading"]

            out.write([stw(T0 + 1.0, stale=True)])  # the STW's inputs stopped: no number, a null
            gone = await server.poll(f"{API}/navigation/speedThroughWater",
                                     lambda b: b.get("timestamp") == iso_ms(T0 + 1.0), START)
            assert gone["value"] is None and gone["$source"] == "edged.sk_bridge"
        assert c.health.counters["sent"] == 6
        assert not any(k.startswith(("unsent", "dropped", "errors")) for k in c.health.counters), c.health.counters
    finally:
        await out.close()
