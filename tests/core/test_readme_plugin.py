"""The example estimator of docs/writing-a-plugin.md works as written: its code block,
run as it stands, registered under its entry point's name, configured by its TOML,
steps depth soundings into estimates (issue 16: documentation that cannot rot)."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from core_dummies import ListOutput

from edged.clock import ReplayClock
from edged.config import parse_config
from edged.records import Estimate, Measurement
from edged.registry import Registry
from edged.runtime import Runtime

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "writing-a-plugin.md"
EXAMPLE = "### Example: the shallowest depth of the last minute"


def _blocks(lang: str) -> list[str]:
    section = GUIDE.read_text().split(EXAMPLE, 1)[1].split("\n### ", 1)[0]
    return re.findall(rf"```{lang}\n(.*?)```", section, re.S)


async def test_the_guide_estimator_plugin_runs_as_written():
    (code,) = _blocks("python")
    (toml,) = _blocks("toml")
    ns: dict = {}
    exec(compile(code, "docs/writing-a-plugin.md:example", "exec"), ns)  # noqa: S102 - our own guide
    conf = tomllib.loads(toml.split("# edged.toml", 1)[1])
    entry = tomllib.loads(toml.split("# edged.toml", 1)[0])["project"]["entry-points"]["edged.estimators"]
    (type_name,) = entry
    registry = Registry(use_entry_points=False)
    registry.register("estimators", type_name, ns["Shallow"])
    registry.register("outputs", "list", ListOutput)
    ListOutput.instances.clear()
    cfg = parse_config({**conf, "outputs": {"rec": {"type": "list"}}}, registry)
    rt = Runtime(cfg, registry, ReplayClock(), replay=True)
    await rt.start()
    try:
        for i, depth in enumerate([30.0, 12.0, 25.0, 40.0, 50.0]):
            rt.clock.advance_to(100.0 + 60.0 * i)
            rt.router.publish(Measurement("depth", "sounder", 100.0 + 60.0 * i, {"depth": depth}))
        await rt.finish_workers(patient=True)
    finally:
        await rt.stop()
    est = [r for r in ListOutput.instances[0].records if isinstance(r, Estimate)]
    fresh = [e for e in est if not e.values.get("stale")]  # (between soundings: published again, stale)
    assert {e.name for e in est} == {"shallows"}
    assert [e.values["depth_min"] for e in fresh] == [30.0, 12.0, 12.0, 12.0, 25.0]  # a 120 s window
