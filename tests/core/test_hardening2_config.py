"""Hardening, second round (issue 32): a configuration may not ask for more than a
gateway computer has. 500 draft instances passed `check-config`; twenty took 3.36 GB."""

from __future__ import annotations

from pathlib import Path

import pytest

from edged.cli import main
from edged.config import MAX_INSTANCES


def _config(tmp_path: Path, role: str, n: int) -> Path:
    body = {
        "estimators": 'type = "draft"\nstw_from = ""\n',
        "outputs": 'type = "mcap"\npath = "{dir}/r{k}.mcap"\n',
        "inputs": 'type = "nmea0183"\ntransport = "file"\npath = "{dir}/in{k}.log"\n',
    }[role]
    text = "".join(f"[{role}.x{k}]\n" + body.format(dir=tmp_path, k=k) for k in range(n))
    p = tmp_path / "edged.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("role", ["estimators", "outputs", "inputs"])
@pytest.mark.parametrize("extra", [1, 8, 488])
def test_more_instances_than_a_role_may_have_are_refused_naming_the_key(role, extra, tmp_path, capsys):
    n = MAX_INSTANCES[role] + extra
    assert main(["check-config", str(_config(tmp_path, role, n))]) == 2
    err = capsys.readouterr().err
    assert f"{role}: {n} instances: at most {MAX_INSTANCES[role]}" in err


@pytest.mark.parametrize("role", ["estimators", "outputs", "inputs"])
def test_the_most_a_role_may_have_passes(role, tmp_path, capsys):
    rc = main(["check-config", str(_config(tmp_path, role, MAX_INSTANCES[role]))])
    err = capsys.readouterr().err
    assert rc == 0, err


@pytest.mark.parametrize("name", ["gps\n", "gps\r", "a\nb", "ok\n\n"])
def test_a_name_with_a_line_end_is_refused(name):
    """`re.match` with `$` let "gps\\n" pass: a name (a source, an instance, a vessel id)
    is a key segment and a file name, and must be one line."""
    from edged.config import ConfigError, parse_config
    from edged.registry import Registry

    with pytest.raises(ConfigError):
        parse_config({"edged": {"vessel_id": name}}, Registry())
