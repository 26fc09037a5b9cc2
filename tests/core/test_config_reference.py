"""The configuration reference (docs/configuration.md) is made from the schemas and kept
up to date (issue 16): a key added, removed or re-documented without `python -m
edged.configdoc --write docs/configuration.md` fails here."""

from __future__ import annotations

from pathlib import Path

from edged.config import CoreConfig, RouterConfig
from edged.configdoc import BEGIN, END, main, reference
from edged.registry import Registry

REFERENCE = Path(__file__).resolve().parents[2] / "docs" / "configuration.md"


def test_the_documented_reference_is_up_to_date(capsys):
    assert main(["--check", str(REFERENCE)]) == 0, capsys.readouterr().err


def test_every_key_of_every_installed_table_is_in_the_reference():
    text = reference(Registry())
    models = [CoreConfig, RouterConfig]
    for role in ("inputs", "estimators", "outputs"):
        for name, cls in Registry().iter(role):
            assert f'`[{role}.<name>]` with `type = "{name}"`' in text
            models.append(cls.Config)
    for model in models:
        for key in model.model_fields:
            if key != "type":
                assert f"| `{key}` |" in text, (model.__name__, key)


def test_the_reference_says_type_default_limits_and_meaning():
    text = reference(Registry())
    row = next(ln for ln in text.splitlines() if ln.startswith("| `health_interval` |"))
    assert row == ("| `health_interval` | number | 1.0 | > 0, ≤ 3600.0 | "
                   "Seconds between health snapshots sent to the outputs. |")


def test_a_stale_block_is_found_and_rewritten(tmp_path, capsys):
    copy = tmp_path / "configuration.md"
    copy.write_text(REFERENCE.read_text().replace("Seconds between health snapshots", "Seconds between beats"))
    assert main(["--check", str(copy)]) == 1
    assert "out of date" in capsys.readouterr().err
    assert main(["--write", str(copy)]) == 0
    assert copy.read_text() == REFERENCE.read_text()
    none = tmp_path / "other.md"
    none.write_text("# no markers\n")
    assert main(["--check", str(none)]) == 2
    assert BEGIN in REFERENCE.read_text() and END in REFERENCE.read_text()
