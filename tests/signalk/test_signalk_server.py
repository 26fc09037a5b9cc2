"""A real signalk-server reads the Signal K output (issue 35): its "Signal K" data
connection over TCP to the output's server, and its REST API then shows edged's STW
and current, with edged as their source; a stale estimate then shows as null. It
drops `design.draft` (its own vessel's is configured), so the mean draft is shown
under `edged.draft.mean`.

Skipped where node is absent or signalk-server is not installed (`make
signalk-server` installs it with npm; `make test` does so first)."""

from __future__ import annotations

from pathlib import Path

import pytest

from bridge_rig import T0, draft, manoeuvre, stw
from edged.clock import ManualClock
from edged.config import parse_config
from edged.registry import Registry
from edged.runtime import Runtime
from edged_signalk.delta import iso_ms
from signalk_server import SignalKServer, skip_reason
from waiting import wait_for

#: signalk-server starts in about 2 s here; its TCP connection retries within 5 s.
START = 20.0
API = "/signalk/v1/api/vessels/self"

WHY_NOT = skip_reason()
pytestmark = pytest.mark.skipif(WHY_NOT is not None, reason=WHY_NOT or "")


async def test_signalk_server_shows_edgeds_stw_and_current_with_edged_as_the_source(tmp_path: Path) -> None:
    """The output run by the daemon's runtime, the estimates published on its router."""
    cfg = parse_config({"outputs": {"sk_bridge": {"type": "signalk", "transport": "tcp", "port": 0}}}, Registry())
    rt = Runtime(cfg, Registry(), ManualClock(T0))
    await rt.start()
    try:
        (host,) = rt.outputs
        info, counters = host.health.info, host.health.counters
        await wait_for(lambda: "port" in info, 5.0)  # the kernel's choice, in health
        async with SignalKServer(tmp_path / "signalk", "127.0.0.1", info["port"]) as server:
            await wait_for(lambda: host.plugin.status().get("clients") == 1, START)  # its data connection is up
            e = stw(T0)
            for rec in (e, manoeuvre(T0)):
                rt.router.publish(rec)

            speed = await server.poll(f"{API}/navigation/speedThroughWater",
                                      lambda b: b.get("value") == e.values["stw"], START)
            assert speed["$source"] == "edged.sk_bridge"
            assert speed["timestamp"] == iso_ms(T0)

            current = await server.poll(f"{API}/environment/current", lambda b: b.get("value") is not None, START)
            assert current["value"] == {"setTrue": e.values["current_set"], "drift": e.values["current"]}
            assert current["$source"] == "edged.sk_bridge"

            heading = await server.poll(f"{API}/navigation/headingTrue", lambda b: "value" in b, START)
            assert heading["value"] == manoeuvre().values["heading"]

            d = draft(T0)  # the mean draft: shown under edged.*, as the server drops design.draft
            rt.router.publish(d)
            mean = await server.poll(f"{API}/edged/draft/mean", lambda b: "value" in b, START)
            assert mean["value"] == d.values["mean_draft"] and mean["$source"] == "edged.sk_bridge"
            assert (await server.get(f"{API}/design/draft"))[0] == 404

            rt.router.publish(stw(T0 + 1.0, stale=True))  # the STW's inputs stopped: no number, a null
            gone = await server.poll(f"{API}/navigation/speedThroughWater",
                                     lambda b: b.get("timestamp") == iso_ms(T0 + 1.0), START)
            assert gone["value"] is None and gone["$source"] == "edged.sk_bridge"
        assert counters["sent"] == 7
        assert not any(k.startswith(("unsent", "dropped", "errors")) for k in counters), counters
    finally:
        await rt.stop()
