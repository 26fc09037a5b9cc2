"""Every bad configuration of the NMEA 2000 output is refused with a message naming
what is wrong: NAME fields out of their bit ranges, an address that is no source
address, an unknown PGN or an impossible rate in `rates`, a gateway without where it
is, strings the product information cannot carry."""

from __future__ import annotations

from typing import Any

import pytest
from pydantic import ValidationError

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged_can.output.citizen import name_of
from edged_can.output.config import Nmea2000OutputConfig
from edged_can.output.plugin import Nmea2000Output


def config(**cfg: Any) -> Nmea2000OutputConfig:
    return Nmea2000OutputConfig.model_validate({"type": "nmea2000", **cfg})


@pytest.mark.parametrize(("key", "value"), [
    ("unique_number", 1 << 21), ("unique_number", -1), ("manufacturer_code", 2048),
    ("device_function", 256), ("device_class", 128), ("device_instance", 256),
    ("system_instance", 16), ("industry_group", 8),
    ("address", 252), ("address", 254), ("address", -1),
    ("heartbeat", 65.6), ("heartbeat", -1.0), ("product_code", 70000),
    ("model_version", "x" * 33), ("serial", "y" * 33), ("stw_sensor_type", "ultrasound"),
    ("transport", "udp"), ("interface", "kvaser"), ("max_age", 0.0), ("colour", "red"),
    ("worker", "process"),  # its link and claim are background tasks of the daemon's loop
])
def test_a_bad_value_is_refused_naming_its_key(key: str, value: Any) -> None:
    with pytest.raises(ValidationError) as err:
        config(**{key: value})
    assert key in str(err.value)


@pytest.mark.parametrize(("cfg", "words"), [
    ({"transport": "ydwg"}, "needs the gateway's host"),
    ({"transport": "actisense"}, "needs a serial device"),
    ({"transport": "actisense", "host": "10.0.0.5"}, "needs a serial device, or a host and port"),
    ({"transport": "actisense", "device": "/dev/ttyUSB0", "host": "h", "port": 1}, "not both"),
])
def test_a_gateway_without_where_it_is_is_refused(cfg: dict[str, Any], words: str) -> None:
    with pytest.raises(ValidationError, match=words):
        config(**cfg)


@pytest.mark.parametrize(("rates", "words"), [
    ({"129029": 1.0}, "unknown message '129029'"),
    ({"heading": 1.0}, "unknown message 'heading'"),
    ({"127250": -1.0}, "not a rate"),
    ({"127250": 5000.0}, "not a rate"),
])
def test_a_bad_rate_is_refused_by_check(rates: dict[str, float], words: str) -> None:
    clock = ManualClock(0.0)
    out = Nmea2000Output(config(rates=rates), PluginContext("n", clock, ComponentHealth("n", "output", "x", clock),
                                                             lambda r: None))
    with pytest.raises(ValueError, match=words):
        out.check()


def test_the_defaults_make_a_marine_navigation_name() -> None:
    c = config()
    name = name_of(c)
    assert c.transport == "can" and c.address == 35
    assert (name >> 60) & 7 == 4 and (name >> 49) & 0x7F == 60 and (name >> 40) & 0xFF == 170
    assert name >> 63 == 1  # arbitrary address capable
    assert config(transport="ydwg", host="192.168.4.1").gateway_port() == 1457
    assert config(rates={"127250": 0.0}).rates == {"127250": 0.0}  # 0 switches a PGN off
