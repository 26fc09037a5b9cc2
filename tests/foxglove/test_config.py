"""Configuration of `[outputs.<name>] type = "foxglove"`: what is refused, naming the
key, and the port it claims against the other plugins."""

from __future__ import annotations

from typing import Any

import pytest

from edged.config import ConfigError, parse_config
from edged.registry import Registry
from edged_foxglove.config import FoxgloveOutputConfig
from edged_foxglove.output import FoxgloveOutput
from edged_zenoh.output import ZenohOutput


def _parse(outputs: dict[str, Any]) -> Any:
    reg = Registry()
    reg.register("outputs", "foxglove", FoxgloveOutput)
    reg.register("outputs", "zenoh", ZenohOutput)
    return parse_config({"outputs": outputs}, reg, file="edged.toml")


def errors(section: dict[str, Any]) -> list[tuple[str, str]]:
    with pytest.raises(ConfigError) as exc:
        _parse({"fox": {"type": "foxglove", **section}})
    return exc.value.errors


@pytest.mark.parametrize(
    "section, key, words",
    [
        ({"port": 70000}, "outputs.fox.port", "65535"),
        ({"port": -1}, "outputs.fox.port", "0"),
        ({"host": ""}, "outputs.fox.host", "not an IP address or a host name"),
        ({"host": "bridge pc"}, "outputs.fox.host", "not an IP address or a host name"),
        ({"host": "http://127.0.0.1"}, "outputs.fox.host", "not an IP address or a host name"),
        ({"meas_max_hz": {"dräft": 2.0}}, "outputs.fox.meas_max_hz", "unknown measurement kind"),
        ({"meas_max_hz": {"draft": -1.0}}, "outputs.fox.meas_max_hz", "not a rate"),
        ({"meas_max_hz": {"draft": 2e6}}, "outputs.fox.meas_max_hz", "not a rate"),
        ({"meas_default_hz": -1.0}, "outputs.fox.meas_default_hz", "0"),
        ({"meas_default_hz": float("nan")}, "outputs.fox.meas_default_hz", ""),
        ({"backlog": 0}, "outputs.fox.backlog", "1"),
        ({"bind": "0.0.0.0"}, "outputs.fox.bind", "unknown key"),
    ],
)
def test_bad_values_are_refused_naming_the_key(section, key, words):
    errs = errors(section)
    assert [k for k, _ in errs] == [key], errs
    assert words in errs[0][1]


def test_defaults_and_accepted_hosts():
    cfg = FoxgloveOutputConfig(type="foxglove")
    assert (cfg.host, cfg.port, cfg.meas_default_hz, cfg.worker) == ("127.0.0.1", 8765, 10.0, "loop")
    assert cfg.estimates and cfg.measurements and cfg.locations and cfg.health
    assert FoxgloveOutputConfig(type="foxglove", host="[::1]").host == "::1"
    assert FoxgloveOutputConfig(type="foxglove", host="bridge-pc.local").host == "bridge-pc.local"
    cfg = FoxgloveOutputConfig(type="foxglove", meas_max_hz={"draft": 2.0})
    assert (cfg.hz("draft"), cfg.hz("heading")) == (2.0, 10.0)


def test_two_servers_on_one_port_are_refused():
    with pytest.raises(ConfigError) as exc:
        _parse({"a": {"type": "foxglove"}, "b": {"type": "foxglove", "host": "0.0.0.0"}})
    assert [k for k, _ in exc.value.errors] == ["outputs.a.port and outputs.b.port"]


def test_its_port_is_claimed_against_zenoh_listening_there():
    with pytest.raises(ConfigError) as exc:
        _parse({"fox": {"type": "foxglove", "port": 7447},
                "zenoh": {"type": "zenoh", "listen": ["tcp/127.0.0.1:7447"]}})
    assert "outputs.fox.port" in str(exc.value) and "outputs.zenoh.listen.0" in str(exc.value)
    # a port 0 (any free one) claims nothing; other ports live side by side
    _parse({"fox": {"type": "foxglove", "port": 0}, "zenoh": {"type": "zenoh"}})
    _parse({"a": {"type": "foxglove"}, "b": {"type": "foxglove", "port": 8766}})
