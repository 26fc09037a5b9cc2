"""The shipped example configuration stays valid as the plugins evolve."""

from pathlib import Path

from edged.cli import main

DEPLOY = Path(__file__).resolve().parents[2] / "deploy"


def test_example_config_is_valid(capsys):
    assert main(["check-config", str(DEPLOY / "edged.toml")]) == 0
    out = capsys.readouterr().out
    assert "5 inputs (gnss1, gyro, doppler, can0, shore)" in out
    assert "2 outputs (zenoh, recorder)" in out
