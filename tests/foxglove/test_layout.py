"""`deploy/foxglove-layout.json` cannot rot: it is what `edged_foxglove.layout` makes,
and every topic and field it names is one the recorder and the Foxglove output make
for the example configuration (`deploy/edged.toml`), by the recorder's own naming
(`edged.channels.encode`) and schemas."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path
from typing import Any, Iterator

import pytest
from edged_draft.estimate import DRAFT_MARKS
from edged_foxglove.layout import ESTIMATE_LOCATION, layout_json
from edged.channels import encode
from edged.schemas import schema_dict

from edged.estimates import ESTIMATE_KINDS
from edged.records import KINDS, Estimate, HealthRecord, Measurement

ROOT = Path(__file__).resolve().parents[2]
LAYOUT = ROOT / "deploy" / "foxglove-layout.json"
CONFIG = ROOT / "deploy" / "edged.toml"
T0 = 1_764_900_000.0


@pytest.fixture(scope="module")
def layout() -> dict[str, Any]:
    return json.loads(LAYOUT.read_text(encoding="utf-8"))


def _channels() -> dict[str, dict[str, Any]]:
    """topic -> JSON schema of every channel the example configuration gives: its
    estimators' estimates, every measurement kind from each of its inputs (with a
    position's LocationFix), health."""
    cfg = tomllib.loads(CONFIG.read_text(encoding="utf-8"))
    records: list[Any] = [HealthRecord(T0, {})]
    for name, body in cfg["estimators"].items():  # (a kind with a position: its LocationFix too)
        fields = ESTIMATE_KINDS[body["type"]].field_names
        values = {"lat": 59.4, "lon": 24.7} if {"lat", "lon"} <= set(fields) else {}
        records.append(Estimate(name, name, T0, values, body["type"]))
    for source in cfg["inputs"]:
        for kind in KINDS:
            values = {"lat": 59.4, "lon": 24.7} if kind == "position" else {}
            records.append(Measurement(kind, source, T0, values))
    return {topic: schema_dict(schema) for rec in records for topic, schema, _ in encode(rec)}


def _scripts(layout: dict[str, Any]) -> dict[str, tuple[list[str], str, str]]:
    """Each user script's (inputs, output, source code)."""
    out = {}
    for sid, script in (layout.get("userScripts") or {}).items():
        code = script["sourceCode"]
        inputs = re.search(r"export const inputs = \[(.*?)\];", code, re.S)
        output = re.search(r'export const output = "(.*?)";', code)
        assert inputs and output, f"user script {sid}: no inputs or output"
        out[sid] = (re.findall(r'"([^"]+)"', inputs.group(1)), output.group(1), code)
    return out


def _paths(node: Any, key: str = "") -> Iterator[str]:
    """Every string in the layout that names a topic (a message path or a topic), in
    values and in keys, except the scripts' code."""
    if isinstance(node, dict):
        for k, v in node.items():
            if k.startswith("/"):
                yield k
            if k != "sourceCode":
                yield from _paths(v, k)
    elif isinstance(node, list):
        for v in node:
            yield from _paths(v, key)
    elif isinstance(node, str) and node.startswith("/"):
        yield node


def _field(schema: dict[str, Any], fields: list[str], where: str) -> None:
    for f in fields:
        props = schema.get("properties") or {}
        assert f in props, f"{where}: no field {f!r} (has {sorted(props)})"
        schema = props[f]


def test_the_file_is_what_the_generator_makes():
    assert LAYOUT.read_text(encoding="utf-8") == layout_json(), (
        "regenerate: .venv/bin/python -m edged_foxglove.layout > deploy/foxglove-layout.json")


def test_every_topic_and_field_named_is_a_channel_of_the_example_configuration(layout):
    channels = _channels()
    scripts = _scripts(layout)
    made_by_scripts = {output for _, output, _ in scripts.values()}
    paths = sorted(set(_paths(layout)))
    assert len(paths) >= 15
    for path in paths:
        topic, _, rest = path.partition(".")
        if topic in made_by_scripts:
            assert topic.startswith("/foxglove_script/") and not rest, path
            continue
        assert topic in channels, f"{path}: {topic} is not a channel edged makes for deploy/edged.toml"
        _field(channels[topic], rest.split(".") if rest else [], path)
    for sid, (inputs, _, code) in scripts.items():
        for topic in inputs:
            assert topic in channels, f"user script {sid}: input {topic} is not a channel"
            _field(channels[topic], [], topic)
            for f in sorted(set(re.findall(r"\bm\.(\w+)", code))):  # what the script reads
                _field(channels[topic], [f], f"user script {sid}")


def _panels(node: Any) -> Iterator[dict[str, Any]]:
    if isinstance(node, dict):
        if node.get("type") == "panel":
            yield node
        for v in node.values():
            yield from _panels(v)
    elif isinstance(node, list):
        for v in node:
            yield from _panels(v)


def test_it_shows_the_map_speeds_manoeuvre_drafts_and_health(layout):
    panels = list(_panels(layout["content"]))
    maps = [p for p in panels if p["panelType"] == "Map"]
    assert len(maps) == 1 and maps[0]["config"]["followTopic"] == "/location/gnss1"
    assert set(maps[0]["config"]["topicColors"]) == {"/location/gnss1", ESTIMATE_LOCATION}
    plotted = {s["value"] for p in panels if p["panelType"] == "Plot" for s in p["config"]["paths"]}
    assert {"/est/stw.stw", "/meas/water_speed/doppler.stw_long", "/est/stw.sog"} <= plotted
    assert {f"/est/manoeuvre.{f}" for f in ("heading", "r", "u", "v")} <= plotted
    assert {f"/est/draft.marks.{m}.mean" for m in DRAFT_MARKS} <= plotted
    assert {"/est/draft.mean_draft", "/est/draft.trim", "/est/draft.list"} <= plotted
    raw = [p for p in panels if p["panelType"] == "RawMessages"]
    assert [p["config"]["topicPath"] for p in raw] == ["/health"]
    assert not _scripts(layout)  # the estimate's fix is a channel, not a script of the browser's


def test_a_stale_name_would_be_caught():
    """The check above fails for a field or topic edged does not make (it can fail)."""
    channels = _channels()
    with pytest.raises(AssertionError):
        _field(channels["/est/stw"], ["stw_estimate"], "/est/stw.stw_estimate")
    assert "/meas/water_speed/log1" not in channels and "/location/doppler" in channels


def test_a_layout_for_other_source_names(capsys: pytest.CaptureFixture[str]) -> None:
    """`edged demo` names its GNSS and log `nmea`: the layout is made for those names."""
    from edged_foxglove.layout import main

    assert main(["--gnss", "nmea", "--log", "nmea"]) == 0
    text = capsys.readouterr().out
    assert '"/location/nmea"' in text and "/meas/velocity_ground/nmea.sog" in text
    assert "/meas/water_speed/nmea.stw_long" in text and "gnss1" not in text and "doppler" not in text
    json.loads(text)
    with pytest.raises(SystemExit) as exc:
        main(["--gnss", "gnss/1"])
    assert exc.value.code == 2 and "is not a source name" in capsys.readouterr().err
