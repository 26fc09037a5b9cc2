"""`edged fleet`: the table logic, and a bounded run against a publishing vessel."""

from __future__ import annotations

import argparse
import asyncio
import io
import json
import math

from edged.records import Estimate, HealthRecord
from edged_zenoh.commands import fleet_main
from edged_zenoh.fleet import FleetTable
from edged_zenoh.output import ZenohOutput, ZenohOutputConfig

T0 = 1_732_350_000.0
HEALTHY = {
    "t": T0,
    "inputs": {"gnss1": {"state": "connected", "ok": True}},
    "outputs": {"zenoh": {"state": "running", "ok": True}},
}


def _j(obj) -> bytes:
    return json.dumps(obj).encode()


def _row(text: str, vessel: str) -> str:
    (line,) = [ln for ln in text.splitlines() if ln.startswith(vessel + " ")]
    return line


def test_table_shows_stw_heading_position_and_state():
    t = FleetTable(stale_after=5.0)
    t.update("vessel/aurora/est/stw", _j({"t": T0, "stw": 6.25}), now=100.0)
    t.update("vessel/aurora/est/manoeuvre", _j({"t": T0, "heading": math.pi / 2, "lat": 60.1, "lon": 24.95}), 100.0)
    t.update("vessel/aurora/health", _j(HEALTHY), 100.0)
    t.update("vessel/borealis/health", _j({"t": T0, "inputs": {"can0": {"state": "backoff", "ok": False}}}), 101.0)
    text = t.render(now=101.5)
    assert text.splitlines()[0].split()[:2] == ["VESSEL", "LAST"]
    assert _row(text, "aurora").split() == ["aurora", "1.5", "s", "6.25", "090.0", "60.10000", "24.95000", "ok"]
    assert _row(text, "borealis").endswith("degraded can0:backoff")
    # Silence makes a vessel stale; a withdrawn liveliness token makes it offline.
    assert _row(t.render(now=106.0), "aurora").endswith("stale")
    t.liveliness("vessel/borealis/alive", False, 106.0)
    assert _row(t.render(now=106.0), "borealis").endswith("offline")


def test_bad_samples_are_counted_not_fatal():
    t = FleetTable()
    t.update("vessel/x/est/stw", b"\xff", 1.0)
    t.update("vessel/x/est/stw", b"[1]", 1.0)
    t.update("elsewhere", _j({}), 1.0)
    t.update("vessel/x/est/stw", _j({"stw": "fast"}), 1.0)  # kept as unknown
    assert t.bad_samples == 3
    assert _row(t.render(2.0), "x").split()[3] == "-"
    assert "(no vessel seen yet)" in FleetTable().render(0.0)


def test_fleet_command_lists_a_running_vessel(make_ctx, free_port, tmp_path):
    port = free_port()
    c = make_ctx("zenoh", "aurora")
    out = ZenohOutput(ZenohOutputConfig.model_validate({"type": "zenoh", "listen": [f"tcp/127.0.0.1:{port}"]}), c.ctx)
    zcfg = tmp_path / "fleet.json5"
    zcfg.write_text('{connect: {endpoints: ["tcp/127.0.0.1:%d"]}}' % port)

    async def scenario() -> str:
        await out.open()
        await asyncio.wait_for(out.connected.wait(), 30)
        out.write(
            [
                Estimate("stw", "stw", T0, {"stw": 5.5}),
                Estimate("manoeuvre", "m", T0, {"heading": math.pi, "lat": 59.5, "lon": 10.25}),
                HealthRecord(T0, HEALTHY),
            ]
        )
        buf = io.StringIO()
        args = argparse.Namespace(zenoh_config=str(zcfg), out=buf, refreshes=1, interval=None, duration=None)
        assert await asyncio.to_thread(fleet_main, args) == 0
        await out.close()
        return buf.getvalue()

    text = asyncio.run(scenario())
    row = _row(text, "aurora").split()
    assert row[3:7] == ["5.50", "180.0", "59.50000", "10.25000"]
    assert row[-1] == "ok"


def test_fleet_command_bad_config_is_a_usage_error(tmp_path, capsys):
    bad = tmp_path / "bad.json5"
    bad.write_text("{mode: ")
    assert fleet_main(argparse.Namespace(zenoh_config=str(bad))) == 2
    assert "bad.json5" in capsys.readouterr().err


def test_a_heading_just_under_a_full_turn_is_000_not_360():
    from edged_zenoh.fleet import _bearing

    assert _bearing(2 * math.pi - 1e-5) == "000.0"
    assert _bearing(math.radians(5.3)) == "005.3" and _bearing(-math.radians(1.0)) == "359.0"
