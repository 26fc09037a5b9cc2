"""The `[outputs.signalk]` table (issue 35): what is refused, with a message that says
why, and the defaults a Signal K server's data connection is set up against."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from bridge_rig import Ctx
from edged_signalk.config import DEFAULT_PORT, SignalKOutputConfig
from edged_signalk.output import SignalKOutput


@pytest.mark.parametrize("cfg, words", [
    ({"context": "vessels.aurora"}, "not a vessel's"),
    ({"context": "self"}, "not a vessel's"),
    ({"context": "vessels.urn:mrn:imo:mmsi:12345"}, "not a vessel's"),
    ({"context": "vessels.self.navigation"}, "not a vessel's"),
    ({"transport": "serial"}, "needs a device"),
    ({"transport": "udp", "port": 0}, "port 0 is none"),
    ({"port": 70000}, "less than or equal to 65535"),
    ({"max_age": 0}, "greater than 0"),
    ({"rates": {"speed": float("inf")}}, "finite number"),
    ({"talker": "ED"}, "Extra inputs are not permitted"),
    ({"worker": "process"}, "daemon's loop only"),
])
def test_bad_configuration_is_refused_with_a_clear_message(cfg: dict, words: str) -> None:
    with pytest.raises(ValidationError, match=words):
        SignalKOutputConfig(type="signalk", **cfg)


@pytest.mark.parametrize("rates, words", [
    ({"VHW": 1.0}, "unknown message 'VHW'"),
    ({"heading": -1.0}, "not a rate"),
    ({"heading": 1e6}, "not a rate"),
])
def test_bad_rates_are_refused_by_check(rates: dict, words: str) -> None:
    out = SignalKOutput(SignalKOutputConfig(type="signalk", rates=rates), Ctx().ctx)
    with pytest.raises(ValueError, match=words):
        out.check()


def test_defaults_and_the_vessel_urns_accepted() -> None:
    c = SignalKOutputConfig(type="signalk")
    assert (c.transport, c.host, c.port, c.context) == ("udp", "127.0.0.1", DEFAULT_PORT, "vessels.self")
    assert DEFAULT_PORT != 10110  # NMEA 0183's
    for ctx in ("vessels.urn:mrn:imo:mmsi:230123456", "vessels.urn:mrn:signalk:uuid:c0d79334-4e25-4245-8892-54e8ccc8021d"):
        assert SignalKOutputConfig(type="signalk", context=ctx).context == ctx


def test_the_entry_point_names_the_output() -> None:
    from importlib.metadata import entry_points

    (ep,) = [e for e in entry_points(group="edged.outputs") if e.name == "signalk"]
    assert ep.load() is SignalKOutput


def test_the_daemons_configuration_names_the_key_of_a_bad_value() -> None:
    from edged.config import ConfigError, parse_config
    from edged.registry import Registry

    good = {"outputs": {"bridge": {"type": "signalk", "transport": "tcp", "port": 10111, "rates": {"heading": 10}}}}
    cfg = parse_config(good, Registry())
    assert cfg.outputs["bridge"].rates == {"heading": 10}
    with pytest.raises(ConfigError) as ei:
        parse_config({"outputs": {"bridge": {"type": "signalk", "context": "vessels.aurora"}}}, Registry(), file="x.toml")
    ((key, why),) = ei.value.errors
    assert key == "outputs.bridge.context" and "not a vessel's" in why
