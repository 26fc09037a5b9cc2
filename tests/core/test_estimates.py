"""Estimate kinds: each declared once, by its estimator's package, registered through
entry points; the docs, schemas and payloads agree with it."""

from __future__ import annotations

import re
from pathlib import Path

from importlib.metadata import EntryPoint

from edged_draft.estimate import DRAFT_MARKS

from edged import estimates
from edged.estimates import (
    COMMON_FIELDS,
    ESTIMATE_KINDS,
    EstimateKind,
    est_field,
    estimate_to_json,
    kinds_markdown,
    register_kind,
)
from edged.jsonpayload import record_json
from edged.records import Estimate

DESIGN = Path(__file__).resolve().parents[2] / "docs" / "DESIGN.md"


def _design_fields(kind: str) -> set[str]:
    """The field names DESIGN §6 lists for `est/<kind>` (backticked, comma-separated)."""
    text = DESIGN.read_text(encoding="utf-8")
    start = text.index(f"- `est/{kind}`:")
    end = text.find("\n- ", start + 1)
    end = text.index("\n## ", start) if end < 0 or text.find("\n## ", start) < end else end
    names: set[str] = set()
    for chunk in re.findall(r"`([^`]+)`", text[start:end]):
        if chunk.startswith(("est/", "{", "paper")):
            continue
        names.update(n.strip() for n in chunk.split(","))
    return names


def test_every_field_design_names_is_defined_and_every_defined_field_is_in_design():
    for name, kind in ESTIMATE_KINDS.items():
        doc = _design_fields(name)
        defined = {f.name for f in kind.fields} | {"t"}
        mark = {f.name for f in kind.mark_fields}
        common = {f.name for f in COMMON_FIELDS}
        assert doc - defined - mark - common == set(), f"{name}: named in DESIGN, not defined"
        assert defined - doc == set(), f"{name}: defined, not in DESIGN §6"
        assert mark <= doc


def test_scored_fields_have_truth_columns_of_the_simulator_and_valid_sigma_paths():
    from edged_sim.truth import columns

    truth = set(columns())
    for kind in ESTIMATE_KINDS.values():
        names = {f.name for f in kind.fields}
        for s in kind.scored_fields():
            assert s.truth in truth, (kind.name, s.path)
            if s.std is not None:
                head = s.std.split(".")[0]
                assert head in names or s.path.startswith("marks."), (kind.name, s.std)
    draft = [s.path for s in ESTIMATE_KINDS["draft"].scored_fields()]
    assert f"marks.{DRAFT_MARKS[0]}.mean" in draft and len(draft) == 6 * 2 + 6


def test_an_estimate_as_json_has_the_common_fields_and_its_time_wins():
    e = Estimate("stw_paper", "stw_paper", 10.0, {"t": 3.0, "stw": 1.0}, kind="stw")
    d = estimate_to_json(e)
    assert d == {"t": 10.0, "kind": "stw", "stale": False, "age": 0.0, "converging": False, "stw": 1.0}
    assert record_json(e) == d
    assert [f.name for f in COMMON_FIELDS] == ["t", "kind", "stale", "age", "converging"]


def test_the_markdown_and_the_mcap_schemas_are_made_from_the_kinds():
    from edged.schemas import schema_dict

    md = kinds_markdown()
    for kind in ESTIMATE_KINDS.values():
        schema = schema_dict(f"edged.est.{kind.name}")
        for f in kind.fields:
            assert f"`{f.name}`" in md
            assert f.name in schema["properties"], (kind.name, f.name)
        assert schema["required"] == ["t", "kind", "stale", "age", "converging"]
    marks = schema_dict("edged.est.draft")["properties"]["marks"]["properties"]
    assert set(marks) == set(DRAFT_MARKS) and "mean" in marks["aft_stbd"]["properties"]


def test_the_kinds_come_from_the_estimators_packages_through_entry_points():
    from edged_draft.estimate import DRAFT
    from edged_manoeuvre.estimate import MANOEUVRE
    from edged_stw.estimate import STW

    assert {"stw", "manoeuvre", "draft"} <= set(ESTIMATE_KINDS)
    assert ESTIMATE_KINDS["stw"] is STW and ESTIMATE_KINDS["manoeuvre"] is MANOEUVRE
    assert ESTIMATE_KINDS["draft"] is DRAFT and DRAFT.marks == DRAFT_MARKS
    # the core names no estimator's marks: they are the kind's
    assert not hasattr(estimates, "DRAFT_MARKS")


def test_kinds_load_lazily_skip_a_broken_one_and_may_be_registered_by_hand(monkeypatch, caplog):
    good = EntryPoint("stw", "edged_stw.estimate:STW", estimates.KINDS_GROUP)
    broken = EntryPoint("broken", "no_such_module_anywhere:KIND", estimates.KINDS_GROUP)
    misnamed = EntryPoint("other", "edged_stw.estimate:STW", estimates.KINDS_GROUP)
    calls = []

    def fake(group: str) -> list[EntryPoint]:
        calls.append(group)
        return [good, broken, misnamed]

    monkeypatch.setattr(estimates, "entry_points", fake)
    kinds = estimates._Kinds()
    assert calls == []  # nothing read before the first use
    assert list(kinds) == ["stw"] and "broken" not in kinds and len(kinds) == 1
    assert calls == [estimates.KINDS_GROUP]  # read once
    assert "broken" in caplog.text and "other" in caplog.text
    toy = EstimateKind("toy", "a test kind", (est_field("x", "m", "x"),))
    kinds.register(toy)
    assert kinds["toy"] is toy and list(kinds) == ["stw", "toy"] and calls == [estimates.KINDS_GROUP]


def test_register_kind_adds_one_beside_the_installed_ones(monkeypatch):
    from edged.schemas import _estimate_kind

    monkeypatch.setattr(ESTIMATE_KINDS, "_registered", {})  # (restored after the test)
    monkeypatch.setattr(ESTIMATE_KINDS, "_all", None)
    toy = EstimateKind("toy_depth", "a test kind", (est_field("depth_min", "m", "shallowest"),))
    register_kind(toy)
    assert ESTIMATE_KINDS["toy_depth"] is toy and "stw" in ESTIMATE_KINDS
    assert "depth_min" in _estimate_kind(toy)["properties"]
