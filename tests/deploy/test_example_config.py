"""The shipped example configuration stays valid as the plugins evolve."""

from pathlib import Path

from edged.cli import main

DEPLOY = Path(__file__).resolve().parents[2] / "deploy"


def test_example_config_is_valid(capsys):
    assert main(["check-config", str(DEPLOY / "edged.toml")]) == 0
    out = capsys.readouterr().out
    assert "5 inputs (gnss1, gyro, doppler, can0, shore)" in out
    # the bridge outputs are there, switched off, and checked all the same
    assert "6 outputs (zenoh, recorder, bridge_nmea, bridge_n2k, signalk, foxglove)" in out


def _commented_tables(text: str, type_: str) -> list[str]:
    """The commented `[inputs.<name>]` examples of `type_`, uncommented, one a string."""
    out, cur = [], None
    for line in text.splitlines():
        s = line[2:] if line.startswith("# ") else None
        if s is not None and s.startswith("[inputs."):
            cur = [s]
            out.append(cur)
        elif cur is not None and s is not None and s.strip():
            cur.append(s)
        else:
            cur = None
    return ["\n".join(t) for t in out if f'type = "{type_}"' in "\n".join(t)]


def test_every_commented_gateway_example_is_a_valid_input(tmp_path, capsys):
    tables = _commented_tables((DEPLOY / "edged.toml").read_text(), "n2k_gateway")
    gateways = set()
    for i, table in enumerate(tables):
        path = tmp_path / f"gw{i}.toml"
        path.write_text(table + "\n")
        assert main(["check-config", str(path)]) == 0, table
        gateways.add(next(ln.split('"')[1] for ln in table.splitlines() if ln.startswith("gateway")))
    capsys.readouterr()
    # one of each gateway kind the issue names: YDWG, Actisense (BST, ASCII, plain), iKonvert, SeaSmart
    assert {"ydwg_raw", "actisense_bst", "actisense_ascii", "actisense_plain", "ikonvert", "pcdin"} <= gateways


def test_every_commented_draft_setting_is_valid(tmp_path, capsys):
    """The example's draft keys, all uncommented, are what the estimator accepts."""
    text = (DEPLOY / "edged.toml").read_text()
    section = text.split("[estimators.draft]\n", 1)[1].split("\n\n", 1)[0]
    keys = [ln[2:].split("#")[0].rstrip() for ln in section.splitlines()
            if ln.startswith("# ") and " = " in ln.split("#")[1] and ln[2].isalpha()]
    assert len(keys) >= 20
    path = tmp_path / "draft.toml"
    path.write_text('[estimators.stw]\ntype = "stw"\n\n[estimators.draft]\ntype = "draft"\n' + "\n".join(keys) + "\n")
    assert main(["check-config", str(path)]) == 0, keys
    assert "estimators (stw, draft)" in capsys.readouterr().out
