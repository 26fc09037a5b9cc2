"""The estimator contract: `edged.estimator.Estimator`, and the example of
docs/writing-an-estimator.md built from that page alone.

The page's files (the code blocks whose first line names a path) are written out as a
package of their own in a temporary directory, with the `.dist-info` that installing
it would make (its entry points from the page's pyproject.toml), so that a subprocess
that has the directory on its path finds it through the entry points, as edged finds
any installed plugin. `edged replay` then runs it on a small log, and its estimates,
their schema and its health are read back from the recording.
"""

from __future__ import annotations

import configparser
import json
import math
import os
import re
import subprocess
import sys
import tomllib
from functools import reduce
from operator import xor
from pathlib import Path

import pytest
from mcap.reader import make_reader

from edged.estimator import ESTIMATES, HEALTH_KEYS, Estimator, handles
from edged.records import Estimate, Measurement

DOC = Path(__file__).resolve().parents[2] / "docs" / "writing-an-estimator.md"
T0 = 1_700_000_000


def _files() -> dict[str, str]:
    """The page's files: fenced blocks whose first line is `# <path>`, by path."""
    out = {}
    for body in re.findall(r"```(?:python|toml)\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S):
        first, _, rest = body.partition("\n")
        m = re.fullmatch(r"# (\S+\.(?:py|toml))", first.strip())
        if m:
            out[m.group(1)] = rest
    return out


def _install(files: dict[str, str], root: Path) -> None:
    """The package under `root`, and the metadata pip would write for it."""
    pyproject = tomllib.loads(files["pyproject.toml"])
    project = pyproject["project"]
    for path, text in files.items():
        if path.endswith(".py"):
            target = root / path
            target.parent.mkdir(parents=True, exist_ok=True)
            (target.parent / "__init__.py").touch()
            target.write_text(text, encoding="utf-8")
    info = root / f"{project['name'].replace('-', '_')}-{project['version']}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {project['version']}\n")
    eps = configparser.ConfigParser()
    eps.optionxform = str  # type: ignore[assignment,method-assign]  # names are case-sensitive
    for group, entries in project["entry-points"].items():
        eps[group] = entries
    with (info / "entry_points.txt").open("w") as f:
        eps.write(f)


def _sentence(body: str) -> str:
    return f"${body}*{reduce(xor, body.encode(), 0):02X}"


def _log(path: Path, speeds: list[float]) -> None:
    """One log reading (VHW, knots) a second, timed by its TAG block."""
    lines = []
    for i, v in enumerate(speeds):
        tag = f"c:{T0 + i}"
        lines.append(f"\\{tag}*{reduce(xor, tag.encode(), 0):02X}\\" + _sentence(f"VWVHW,,T,,M,{v / 0.514444:.3f},N,,K"))
    path.write_text("\n".join(lines) + "\n")


def _speeds() -> list[float]:
    """5 m/s with ±0.15 m/s of a deterministic wobble, and one reading far off."""
    speeds = [5.0 + 0.15 * math.sin(1.7 * i) for i in range(60)]
    speeds[30] = 9.0
    return speeds


def test_the_documented_estimator_runs_from_the_page_alone(tmp_path: Path) -> None:
    files = _files()
    assert {"edged_steady/estimate.py", "edged_steady/plugin.py", "pyproject.toml", "edged.toml"} <= files.keys()
    _install(files, tmp_path / "site")
    (tmp_path / "edged.toml").write_text(files["edged.toml"])
    _log(tmp_path / "voyage.log", _speeds())
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path / "site"), os.environ.get("PYTHONPATH", "")])}
    for argv in (["check-config", "edged.toml"],
                 ["replay", "voyage.log", "-c", "edged.toml", "--record", "voyage.mcap", "--no-zenoh", "--no-progress"]):
        run = subprocess.run([sys.executable, "-m", "edged.cli", *argv], cwd=tmp_path, env=env, capture_output=True,
                             text=True, timeout=120)
        assert run.returncode == 0, (argv, run.stdout, run.stderr)
    estimates, schemas, health = [], set(), None
    with (tmp_path / "voyage.mcap").open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if channel.topic == "/est/log_smooth":
                estimates.append(json.loads(message.data))
                schemas.add(schema.name)
            elif channel.topic == "/health":
                health = json.loads(message.data)
    assert schemas == {"edged.est.steady_speed"}  # its kind, registered by its own package
    assert len(estimates) == 59  # every reading but the one the gate kept out
    assert all(e["kind"] == "steady_speed" and not e["stale"] for e in estimates)
    assert [e["converging"] for e in estimates] == [True] * 10 + [False] * 49
    assert abs(estimates[-1]["speed"] - 5.0) < 0.1 and 0.05 < estimates[-1]["speed_std"] < 0.1
    assert T0 + 30 not in {e["t"] for e in estimates}
    filt = health["estimators"]["log_smooth"]["info"]["filter"]
    assert HEALTH_KEYS <= filt.keys() and filt["started"] is True
    assert filt["seen"] == {"water_speed": 60}
    assert filt["rejected"] == {"water_speed.gate": 1} and filt["innovation"]["water_speed"]["gated"] == 1
    assert filt["innovation"]["water_speed"]["updates"] == 58
    assert 0.2 < filt["innovation"]["water_speed"]["nis_mean"] < 2.0


# -- the base class itself ---------------------------------------------------------------
class _Cfg:
    upstream_name: str | None = "stw"


class _Core(Estimator):
    @classmethod
    def upstream(cls, cfg: _Cfg) -> tuple[str, ...]:
        return (cfg.upstream_name,) if cfg.upstream_name else ()

    def __init__(self, cfg: _Cfg) -> None:
        super().__init__(cfg)
        self.got: list[tuple[str, object]] = []

    @handles("heading", "yaw_rate")
    def turned(self, m: Measurement) -> None:
        self.got.append(("turn", m.kind))

    @handles(ESTIMATES)
    def speed(self, e: Estimate) -> list[Estimate]:
        self.got.append(("est", e.name))
        return [Estimate("", "", e.t, {"seen": e.name})]

    def details(self) -> dict[str, int]:
        return {"turns": sum(1 for what, _ in self.got if what == "turn")}


def test_one_dispatch_table_and_the_inputs_from_the_configuration_alone() -> None:
    assert _Core.consumes(_Cfg()) == {"heading", "yaw_rate", "est/stw"}
    off = _Cfg()
    off.upstream_name = None
    assert _Core.consumes(off) == {"heading", "yaw_rate"}
    core = _Core(_Cfg())
    assert core.inputs == _Core.consumes(_Cfg())
    assert core.step(Measurement("heading", "gyro", 1.0, {"heading": 0.1})) == []
    assert core.step(Measurement("position", "gps", 1.0, {})) == []  # not an input: not seen
    assert core.step(Estimate("other", "other", 2.0, {})) == []  # not the instance it reads
    out = core.step(Estimate("stw", "stw", 2.0, {}))
    assert [e.values for e in out] == [{"seen": "stw"}]
    assert core.got == [("turn", "heading"), ("est", "stw")]
    assert core.seen == {"est/stw": 1, "heading": 1, "yaw_rate": 0}
    assert not _Core.ticks and core.tick(3.0) == []


def test_every_core_reports_the_same_health_keys_then_its_own() -> None:
    core = _Core(_Cfg())
    core.updated("heading", 0.5, 1)
    core.gated("heading")
    core.reset("a gap", 9.0)
    core.rejected["yaw_rate.incomplete"] += 1
    h = core.health()
    assert set(h) == HEALTH_KEYS | {"turns"}
    assert h["rejected"] == {"heading.gate": 1, "yaw_rate.incomplete": 1}
    assert h["innovation"]["heading"]["gated"] == 1 and h["innovation"]["heading"]["updates"] == 1
    assert (h["resets"], h["last_reset"], h["last_reset_t"]) == (1, "a gap", 9.0)
    assert h["problems"] == []


def test_a_core_that_ticks_says_so_and_one_that_misdeclares_is_refused() -> None:
    class Ticking(_Core):
        def tick(self, t: float) -> list[Estimate]:
            return [Estimate("", "", t, {})]

    assert Ticking.ticks and not _Core.ticks

    class Clash(_Core):
        def details(self) -> dict[str, int]:
            return {"seen": 1}

    with pytest.raises(ValueError, match="seen"):
        Clash(_Cfg()).health()

    class NoHandler(Estimator):
        @classmethod
        def upstream(cls, cfg: object) -> tuple[str, ...]:
            return ("stw",)

    with pytest.raises(TypeError, match="ESTIMATES"):
        NoHandler.consumes(None)
