"""One zenoh configuration path: safe defaults, settings, json5 drop-ins, in that order."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import zenoh
from pydantic import ValidationError

from edged_zenoh.commands import FLEET_DEFAULTS, ROUTER_DEFAULTS, command_config
from edged_zenoh.output import ZenohOutputConfig
from edged.ratelimit import DataTimeRateLimiter
from edged_zenoh.zconfig import (
    ZenohConfigError,
    ZenohSettings,
    endpoint_in_use,
    free_port_endpoint,
    listen_endpoints,
    session_config,
    to_zenoh,
)

DEPLOY = Path(__file__).resolve().parents[2] / "deploy" / "zenoh"


def _settings(**kw) -> ZenohSettings:
    return ZenohSettings.model_validate(kw)


def test_a_fresh_install_exposes_nothing():
    cfg = session_config(_settings(), config_dir=Path("."))
    z = to_zenoh(cfg)
    assert json.loads(z.get_json("mode")) == "peer"
    assert json.loads(z.get_json("listen/endpoints")) == ["tcp/127.0.0.1:7447"]
    assert json.loads(z.get_json("connect/endpoints")) == []
    assert json.loads(z.get_json("scouting/multicast/enabled")) is False
    assert json.loads(z.get_json("scouting/gossip/enabled")) is False
    for defaults in (ROUTER_DEFAULTS, FLEET_DEFAULTS):
        assert all(ep.startswith("tcp/127.0.0.1:") for ep in listen_endpoints(defaults))
        assert defaults["scouting"]["multicast"]["enabled"] is False


def test_json5_file_merges_key_by_key_and_the_command_line_wins(tmp_path):
    plugin_file = tmp_path / "site.json5"
    plugin_file.write_text(
        """{
  // the shore link, comments and trailing commas allowed
  connect: { endpoints: ["tcp/10.0.0.1:7447",], },
  scouting: { multicast: { enabled: true } },
}"""
    )
    cli_file = tmp_path / "cli.json5"
    cli_file.write_text('{mode: "client", connect: {timeout_ms: 500}}')
    s = _settings(listen=["tcp/127.0.0.1:9000"], zenoh_config=str(plugin_file))
    cfg = session_config(s, config_dir=tmp_path, cli_file=cli_file)
    assert cfg["connect"] == {"endpoints": ["tcp/10.0.0.1:7447"], "timeout_ms": 500}
    assert cfg["scouting"] == {"multicast": {"enabled": True}, "gossip": {"enabled": False}}
    assert cfg["listen"] == {"endpoints": ["tcp/127.0.0.1:9000"]}
    assert cfg["mode"] == "client"
    to_zenoh(cfg)


def test_relative_paths_are_taken_from_the_configuration_folder(tmp_path):
    (tmp_path / "z.json5").write_text("{}")
    cfg = ZenohOutputConfig.model_validate(
        {"type": "zenoh", "zenoh_config": "z.json5", "tls": {"root_ca_certificate": "certs/ca.pem"}},
        context={"config_dir": tmp_path},
    )
    assert cfg.zenoh_config == tmp_path / "z.json5"
    tls = session_config(cfg, config_dir=tmp_path)["transport"]["link"]["tls"]
    assert tls == {"root_ca_certificate": str(tmp_path / "certs" / "ca.pem")}


@pytest.mark.parametrize(
    ("text", "match"),
    [("{mode: ", "json5 syntax"), ("[1]", "top level must be an object"), ('{mode: "banana"}', "rejected by zenoh")],
)
def test_bad_zenoh_files_are_configuration_errors_naming_the_file(tmp_path, text, match):
    p = tmp_path / "bad.json5"
    p.write_text(text)
    with pytest.raises(ValidationError, match=match) as info:
        ZenohOutputConfig.model_validate({"type": "zenoh", "zenoh_config": str(p)})
    assert "bad.json5" in str(info.value)
    with pytest.raises(ZenohConfigError, match=match):
        command_config(ROUTER_DEFAULTS, str(p))


def test_missing_file_and_bad_settings_are_errors(tmp_path):
    with pytest.raises(ZenohConfigError, match="cannot read"):
        command_config(FLEET_DEFAULTS, str(tmp_path / "nope.json5"))
    with pytest.raises(ValidationError, match="not a zenoh endpoint"):
        _settings(listen=["127.0.0.1:7447"])
    with pytest.raises(ValidationError, match="mode"):
        _settings(mode="router")  # a daemon plugin is never the site router
    with pytest.raises(ValidationError, match="wildcard"):
        ZenohOutputConfig.model_validate({"type": "zenoh", "key_prefix": "vessel/*"})
    with pytest.raises(ValidationError, match="unknown measurement kind"):
        ZenohOutputConfig.model_validate({"type": "zenoh", "meas_max_hz": {"wind": 1}})
    with pytest.raises(ValidationError, match="extra"):
        ZenohOutputConfig.model_validate({"type": "zenoh", "lisen": []})


def test_shipped_router_configs_are_valid_zenoh_configs():
    for name in ("router.json5", "router-tls.json5"):
        cfg = command_config(ROUTER_DEFAULTS, str(DEPLOY / name))
        assert cfg["mode"] == "router"
        assert cfg["scouting"]["multicast"]["enabled"] is False
    tls = command_config(ROUTER_DEFAULTS, str(DEPLOY / "router-tls.json5"))
    assert all(ep.startswith("tls/") for ep in listen_endpoints(tls))
    assert tls["access_control"]["enabled"] is True
    # The ACL itself is accepted by a running router (certificates aside).
    del tls["transport"]
    tls["listen"] = {"endpoints": ["tcp/127.0.0.1:0"]}
    zenoh.open(to_zenoh(tls)).close()


def test_taken_endpoint_is_detected_and_replaced():
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        ep = f"tcp/127.0.0.1:{s.getsockname()[1]}"
        assert endpoint_in_use(ep)
        new = free_port_endpoint(ep)
        assert new != ep and new.startswith("tcp/127.0.0.1:") and not endpoint_in_use(new)
    assert not endpoint_in_use("udp/127.0.0.1:1")  # only TCP-like endpoints are judged


def test_rate_limit_grid_keeps_a_jittery_sensor_at_its_rate():
    lim = DataTimeRateLimiter()
    t0 = 1_732_350_000.0
    jitter = [0.0, -0.004, 0.003, -0.002, 0.004, 0.0, -0.003, 0.002, -0.001, 0.001] * 10
    ts = [t0 + i * 0.1 + j for i, j in enumerate(jitter)]
    assert sum(lim.allow("k", t, 10.0) for t in ts) >= 99


def test_rate_limit_after_a_gap_and_after_time_steps_back():
    lim = DataTimeRateLimiter()
    t0 = 1_732_350_000.0
    assert [lim.allow("k", t0 + dt, 1.0) for dt in (0.0, 0.5, 1.0, 10.0, 10.5, 11.0)] == [
        True, False, True, True, False, True,  # silence earns no burst
    ]
    assert lim.allow("k", t0 + 10.9, 1.0) is False  # small reordering: dropped
    assert lim.allow("k", t0, 1.0) is True  # a new recording starts earlier: begin again
    assert lim.allow("other", t0, 0.0) is False


def test_input_is_by_default_a_client_of_the_local_endpoint(make_ctx):
    from edged_zenoh.input import ZenohInput, ZenohInputConfig

    def cfg_of(**kw) -> dict:
        inp = ZenohInput(ZenohInputConfig.model_validate({"type": "zenoh", **kw}), make_ctx("shore", "v").ctx)
        return session_config(inp.config, config_dir=Path("."), base=inp._base_config())

    default = cfg_of()
    assert (default["mode"], listen_endpoints(default), default["connect"]["endpoints"]) == (
        "client", [], ["tcp/127.0.0.1:7447"]
    )
    assert cfg_of(connect=["tcp/127.0.0.1:9"])["mode"] == "client"  # unset mode stays the input's own
    peer = cfg_of(mode="peer")
    assert (peer["mode"], listen_endpoints(peer)) == ("peer", ["tcp/127.0.0.1:7447"])


def test_run_with_a_bad_zenoh_config_file_exits_2_naming_it(tmp_path, capsys):
    from edged.cli import main

    bad = tmp_path / "bad.json5"
    bad.write_text("{ mode: 'peer', listen: ")
    cfg = tmp_path / "edged.toml"
    cfg.write_text('[outputs.zenoh]\ntype = "zenoh"\n')
    assert main(["run", "-c", str(cfg), "--zenoh-config", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "outputs.zenoh" in err and "bad.json5" in err and "json5 syntax" in err
