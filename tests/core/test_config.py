"""Every configuration error path names the file, the key and the reason."""

from __future__ import annotations

import pytest

from edged.cli import main
from edged.config import ConfigError, load_config
from edged.commands import dispatch
from edged.cli import build_parser


def _errors(path, registry) -> list[tuple[str, str]]:
    with pytest.raises(ConfigError) as ei:
        load_config(path, registry)
    assert str(path) in str(ei.value)
    return ei.value.errors


GOOD = """
[edged]
vessel_id = "mv-test"

[router]
failover_timeout = 3.0
[router.priority]
heading = ["gyro", "can0.28"]

[inputs.gyro]
type = "dummy"
lines = ["1.0 heading heading=0.5"]

[estimators.sum]
type = "sum"
reorder_window = 0.5

[outputs.rec]
type = "list"
"""


def test_good_config_loads(write_config, registry):
    cfg = load_config(write_config(GOOD), registry)
    assert cfg.edged.vessel_id == "mv-test"
    assert cfg.router.priority == {"heading": ["gyro", "can0.28"]}
    assert cfg.inputs["gyro"].lines == ["1.0 heading heading=0.5"]
    assert cfg.estimators["sum"].reorder_window == 0.5
    assert list(cfg.outputs) == ["rec"]


@pytest.mark.parametrize(
    "text, key, reason",
    [
        ("[bogus]\nx=1\n", "bogus", "unknown section"),
        ("[edged]\nvesel_id='x'\n", "edged.vesel_id", "unknown key"),
        ("[edged]\nhealth_interval='fast'\n", "edged.health_interval", "valid number"),
        ("[edged]\nhealth_interval=0\n", "edged.health_interval", "greater than 0"),
        ("[edged]\nvessel_id='a/b'\n", "edged.vessel_id", "Zenoh key"),
        ("[edged]\nlog_level='loud'\n", "edged.log_level", "'debug'"),
        ("edged = 3\n", "edged", "must be a table"),
        ("[router.priority]\nhedding=['a']\n", "router.priority", "unknown measurement kind 'hedding'"),
        ("[router.priority]\nheading=['a','a']\n", "router.priority", "listed twice"),
        ("[router]\nfailover_timeout=-1\n", "router.failover_timeout", "greater than 0"),
        ("inputs = 3\n", "inputs", "table of named plugins"),
        ("[inputs]\ngps = 3\n", "inputs.gps", "must be a table"),
        ("[inputs.gps]\nport = 1\n", "inputs.gps.type", "missing"),
        ("[inputs.gps]\ntype = 'nmea9999'\n", "inputs.gps.type", "no input plugin named 'nmea9999'"),
        ("[inputs.gps]\ntype = 'dummy'\nlinez = []\n", "inputs.gps.linez", "unknown key"),
        ("[inputs.gps]\ntype = 'dummy'\nfail_times = 'x'\n", "inputs.gps.fail_times", "valid integer"),
        ("[inputs.'a b']\ntype = 'dummy'\n", "inputs.a b", "name"),
        ("[estimators.s]\ntype = 'sum'\nqueue_size = 'big'\n", "estimators.s.queue_size", "valid integer"),
        ("[outputs.o]\ntype = 'list'\nfail_writes = [1]\n", "outputs.o.fail_writes", "valid integer"),
    ],
)
def test_errors_name_the_key(write_config, registry, text, key, reason):
    errs = _errors(write_config(text), registry)
    assert any(k == key and reason in r for k, r in errs), errs


def test_all_errors_reported_at_once(write_config, registry):
    errs = _errors(write_config("[edged]\nfoo=1\nbar=2\n[inputs.x]\ntype='dummy'\nbaz=3\n"), registry)
    assert {k for k, _ in errs} == {"edged.foo", "edged.bar", "inputs.x.baz"}


def test_toml_syntax_error_names_line(write_config, registry):
    errs = _errors(write_config("[edged]\nvessel_id = \n"), registry)
    assert "TOML syntax" in errs[0][1] and "line 2" in errs[0][1]


def test_unreadable_and_non_utf8_files(tmp_path, registry):
    errs = _errors(tmp_path / "missing.toml", registry)
    assert "cannot read" in errs[0][1]
    p = tmp_path / "latin.toml"
    p.write_bytes(b"[edged]\nvessel_id = '\xe9'\n")
    assert "UTF-8" in _errors(p, registry)[0][1]


def test_check_config_exit_codes(write_config, registry, capsys):
    good = write_config(GOOD)
    assert dispatch(build_parser().parse_args(["check-config", str(good)]), registry) == 0
    assert "OK" in capsys.readouterr().out
    bad = write_config("[edged]\nvessel_id = 5\n", "bad.toml")
    assert dispatch(build_parser().parse_args(["check-config", str(bad)]), registry) == 2
    err = capsys.readouterr().err
    assert f"{bad}: edged.vessel_id: Input should be a valid string" in err


def test_run_with_bad_config_exits_2_before_starting(write_config, capsys):
    bad = write_config("[edged]\nnope = 1\n")
    assert main(["run", "-c", str(bad)]) == 2
    assert "edged.nope: unknown key" in capsys.readouterr().err


def test_plugin_check_failure_is_a_configuration_error(write_config, registry, capsys):
    cfg = write_config('[outputs.rec]\ntype = "list"\nmissing_file = "/nope.json5"\n')
    assert dispatch(build_parser().parse_args(["run", "-c", str(cfg)]), registry) == 2
    assert f"{cfg}: outputs.rec: /nope.json5: no such file" in capsys.readouterr().err
