"""The sim's logs through edged's own log readers and inputs (`open` + `make_decoder`): nothing is
rejected from a clean run, and from the faults run exactly what was injected, by reason."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged_sim.cli import main
from edged.cli import build_parser

import edged_can.plugin as can_plugin
import edged_nmea0183.plugin as nmea_plugin
from edged_can.logs import CANDUMP
from edged_nmea0183.logs import NMEA0183

#: Injected damage -> the counter the inputs raise for it.
REASONS = {
    "bad_checksum": ("nmea.log", "rejected.checksum"),
    "garbage": ("nmea.log", "rejected.no_start"),
    "impossible_value": ("nmea.log", "invalid.GGA"),
    "bad_length": ("can.log", "rejected.dbc_frame"),
}
#: log -> (its reader, the input whose decoder reads its records)
INPUTS = {"nmea.log": (NMEA0183, nmea_plugin.Nmea0183Input), "can.log": (CANDUMP, can_plugin.CanInput)}


def _replay(path: Path) -> tuple[dict[str, int], int]:
    reader, cls = INPUTS[path.name]
    health = ComponentHealth(path.stem, "input", cls.__name__, ManualClock())
    decoders: dict = {}
    n = 0
    with open(path, "rb") as stream:
        for raw in reader.open(stream, "sim", health, ReplayOptions(path=path)):
            dec = decoders.get(raw.source) or decoders.setdefault(raw.source, cls.make_decoder(raw.source, None, health))
            n += len(dec.decode(raw))
    return dict(health.counters), n


def _bad(counters: dict[str, int]) -> dict[str, int]:
    return {k: v for k, v in counters.items() if k.startswith(("rejected.", "invalid.")) or k == "errors"}


def _run(tmp: Path, scenario: str, duration: str) -> Path:
    assert main(build_parser().parse_args(["sim", scenario, "--out", str(tmp), "--duration", duration, "--seed", "5"])) == 0
    return tmp


@pytest.mark.parametrize("scenario", ["draft-squat", "stw-cross-current"])
def test_clean_logs_replay_with_zero_rejects(tmp_path: Path, scenario: str) -> None:
    out = _run(tmp_path, scenario, "60" if scenario.startswith("draft") else "1300")
    for name in INPUTS:
        counters, measurements = _replay(out / name)
        assert _bad(counters) == {}, (name, counters)
        assert measurements > 0 and not any(k.endswith(".lost") or k == "dbc.lost" for k in counters), counters


def test_faults_replay_rejects_exactly_what_was_injected(tmp_path: Path) -> None:
    out = _run(tmp_path, "faults", "120")
    meta = json.loads((out / "meta.json").read_text())
    injected = meta["faults"]["injected"]
    counters = {name: _replay(out / name)[0] for name in INPUTS}
    for reason, (file, counter) in REASONS.items():
        assert counters[file].get(counter, 0) == injected.get(reason, 0), (reason, counters[file])
    rejected = {f: sum(v for k, v in c.items() if k.startswith("rejected.")) for f, c in counters.items()}
    assert rejected == {
        "nmea.log": injected.get("bad_checksum", 0) + injected.get("garbage", 0),
        "can.log": injected.get("bad_length", 0),
    }
    draft_lost = sum(v for k, v in meta["faults"]["dropouts"].items() if k.startswith("draft."))
    truncated_marks = counters["can.log"].get("dbc.lost", 0) - draft_lost
    assert 0 <= truncated_marks <= injected.get("bad_length", 0)  # a truncated mark frame is lost too
