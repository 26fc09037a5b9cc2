"""Configuration: per-transport requirements and errors that name the key."""

from __future__ import annotations

import pytest

from edged.config import ConfigError, parse_config
from edged.registry import Registry
from edged_nmea0183.config import Nmea0183Config
from edged_nmea0183.plugin import Nmea0183Input


def errors(section: dict) -> list[tuple[str, str]]:
    reg = Registry()
    reg.register("inputs", "nmea0183", Nmea0183Input)
    with pytest.raises(ConfigError) as exc:
        parse_config({"inputs": {"gnss1": {"type": "nmea0183", **section}}}, reg, file="edged.toml")
    return exc.value.errors


@pytest.mark.parametrize(
    "section, key",
    [
        ({"transport": "tcp", "port": 10110}, "inputs.gnss1.host"),
        ({"transport": "tcp", "host": "mux.local"}, "inputs.gnss1.port"),
        ({"transport": "serial"}, "inputs.gnss1.device"),
        ({"transport": "udp"}, "inputs.gnss1.port"),
        ({"transport": "file"}, "inputs.gnss1.path"),
        ({"transport": "serial", "device": "/dev/ttyUSB0", "baudrate": 0}, "inputs.gnss1.baudrate"),
        ({"transport": "udp", "port": 70000}, "inputs.gnss1.port"),
        ({"transport": "pigeon"}, "inputs.gnss1.transport"),
        ({"transport": "tcp", "host": "h", "port": 1, "checksum": "maybe"}, "inputs.gnss1.checksum"),
        ({"transport": "tcp", "host": "h", "port": 1, "watchdog": 0}, "inputs.gnss1.watchdog"),
        ({"transport": "tcp", "host": "h", "port": 1, "backoff_initial": 5, "backoff_max": 1}, "inputs.gnss1.backoff_max"),
        ({"transport": "tcp", "host": "h", "port": 1, "variation": 200}, "inputs.gnss1.variation"),
        ({"transport": "tcp", "host": "h", "port": 1, "baud": 4800}, "inputs.gnss1.baud"),  # typo: unknown key
    ],
)
def test_errors_name_the_key(section, key):
    errs = errors(section)
    assert key in [k for k, _ in errs], errs


def test_missing_key_message_says_why():
    ((key, msg),) = errors({"transport": "tcp", "port": 10110})
    assert key == "inputs.gnss1.host" and "required when transport is 'tcp'" in msg


def test_defaults():
    c = Nmea0183Config(type="nmea0183", transport="udp", port=10110)
    assert (c.bind, c.broadcast, c.checksum, c.watchdog, c.baudrate) == ("127.0.0.1", False, "require", 10.0, 4800)
    assert c.variation is None and c.vbw_ground is False


def test_entry_point_is_installed():
    assert Registry().get("inputs", "nmea0183") is Nmea0183Input
    assert Nmea0183Input.protocol == "nmea0183"
