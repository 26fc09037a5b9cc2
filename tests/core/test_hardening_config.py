"""Configuration that `check-config` passes must be configuration `run` starts with.

Issue 10, "Configuration that check-config passes and run refuses": queue sizes of 0,
-5 or 10^20, infinite backoffs and timeouts, two inputs on one UDP port or serial
device, and one name in two roles were all accepted by `check-config`; `run` then
crashed with a traceback or started a link that never retried. Each is now refused by
both commands alike (exit 2, the same message naming the key, no traceback), before
anything starts.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import edged.commands
import edged.runcmd
from edged.backoff import Backoff
from edged.cli import main
from edged.config import ConfigError, load_config, parse_config
from edged.plugin import InputConfig, InputPlugin, OutputConfig, OutputPlugin
from edged.registry import Registry

REPO = Path(__file__).resolve().parents[2]

TCP = 'type = "nmea0183"\ntransport = "tcp"\nhost = "127.0.0.1"\nport = 10110\n'
UDP = 'type = "nmea0183"\ntransport = "udp"\n'
SERIAL = 'type = "nmea0183"\ntransport = "serial"\n'
ZOUT = 'type = "zenoh"\nlisten_fallback = true\n'
CAN = 'type = "can"\ninterface = "virtual"\n'


def mcap(tmp: Path, extra: str = "") -> str:
    return f'[outputs.rec]\ntype = "mcap"\ndirectory = "{tmp / "rec"}"\n{extra}'


# (name, configuration text (with {tmp}), the keys and reasons the message must hold)
BAD: list[tuple[str, str, list[tuple[str, str]]]] = [
    ("queue-0", "MCAP queue_size = 0\n", [("outputs.rec.queue_size", "greater than or equal to 1")]),
    ("queue-neg", "MCAP queue_size = -5\n", [("outputs.rec.queue_size", "greater than or equal to 1")]),
    (
        "queue-huge",
        "MCAP queue_size = 99999999999999999999\n",
        [("outputs.rec.queue_size", "less than or equal to 10000000")],
    ),
    (
        "zenoh-queue-0",
        f"[outputs.z]\n{ZOUT}queue_size = 0\n",
        [("outputs.z.queue_size", "greater than or equal to 1")],
    ),
    ("shutdown-inf", "[edged]\nshutdown_timeout = inf\n", [("edged.shutdown_timeout", "finite number")]),
    ("shutdown-long", "[edged]\nshutdown_timeout = 601\n", [("edged.shutdown_timeout", "less than or equal to 600")]),
    ("health-nan", "[edged]\nhealth_interval = nan\n", [("edged.health_interval", "finite number")]),
    ("health-long", "[edged]\nhealth_interval = 3601\n", [("edged.health_interval", "less than or equal to 3600")]),
    ("failover-inf", "[router]\nfailover_timeout = inf\n", [("router.failover_timeout", "finite number")]),
    (
        "backoff-inf",
        f"[inputs.g]\n{TCP}backoff_initial = inf\nbackoff_max = inf\n",
        [("inputs.g.backoff_initial", "finite number"), ("inputs.g.backoff_max", "finite number")],
    ),
    (
        "backoff-long",
        f"[inputs.g]\n{TCP}backoff_max = 86401\n",
        [("inputs.g.backoff_max", "less than or equal to 86400")],
    ),
    ("nmea-watchdog-inf", f"[inputs.g]\n{TCP}watchdog = inf\n", [("inputs.g.watchdog", "finite number")]),
    (
        "nmea-variation-nan",
        f"[inputs.g]\n{TCP}variation = nan\n",
        [("inputs.g.variation", "finite number")],
    ),
    ("can-watchdog-inf", f"[inputs.c]\n{CAN}watchdog = inf\n", [("inputs.c.watchdog", "finite number")]),
    ("can-backoff-nan", f"[inputs.c]\n{CAN}backoff_initial = nan\n", [("inputs.c.backoff_initial", "finite number")]),
    (
        "can-bitrate-huge",
        f"[inputs.c]\n{CAN}bitrate = 99999999999999999999\n",
        [("inputs.c.bitrate", "less than or equal to 16000000")],
    ),
    ("zenoh-retry-inf", f"[outputs.z]\n{ZOUT}retry_max = inf\n", [("outputs.z.retry_max", "finite number")]),
    (
        "zenoh-retry-order",
        f"[outputs.z]\n{ZOUT}retry_initial = 5.0\nretry_max = 1.0\n",
        [("outputs.z.retry_max", "must be >= retry_initial (5.0)")],
    ),
    (
        "zenoh-port",
        f'[outputs.z]\n{ZOUT}listen = ["tcp/127.0.0.1:70000"]\n',
        [("outputs.z.listen", "port 70000 outside 0..65535")],
    ),
    ("mcap-retry-inf", "MCAP retry_seconds = inf\n", [("outputs.rec.retry_seconds", "finite number")]),
    ("mcap-keep-inf", "MCAP keep_gib = inf\n", [("outputs.rec.keep_gib", "finite number")]),
    ("mcap-rotate-nan", "MCAP rotate_seconds = nan\n", [("outputs.rec.rotate_seconds", "finite number")]),
    (
        "log-file-no-folder",
        '[edged]\nlog_file = "TMP/nope/edged.log"\n',
        [("edged.log_file", "no directory 'TMP/nope'")],
    ),
    ("log-file-folder", '[edged]\nlog_file = "TMP"\n', [("edged.log_file", "is a directory")]),
    (
        "can-source-name-slash",
        f'[inputs.c]\n{CAN}[inputs.c.source_names]\n28 = "gy/ro"\n',
        [("inputs.c.source_names.28", "Zenoh key segment")],
    ),
    (
        "can-iso-name-space",
        f'[inputs.c]\n{CAN}[inputs.c.iso_names]\n"0xc0788c00e7e04312" = "gyro 2"\n',
        [("inputs.c.iso_names.0xc0788c00e7e04312", "Zenoh key segment")],
    ),
    (
        "can-source-template-slash",
        f'[inputs.c]\n{CAN}[[inputs.c.signals]]\nmessage = "DraftMark"\nkind = "draft"\n'
        'fields = {}\nsource = "{bus}/{message}"\n',
        [("inputs.c.signals.0.source", "Zenoh key segment")],
    ),
    (
        "udp-same-port",
        f"[inputs.a]\n{UDP}port = 10110\n[inputs.b]\n{UDP}port = 10110\n",
        [("inputs.a.port and inputs.b.port", "both listen on udp 127.0.0.1:10110")],
    ),
    (
        "udp-any-address",
        f'[inputs.a]\n{UDP}port = 10110\nbind = "0.0.0.0"\n[inputs.b]\n{UDP}port = 10110\nbroadcast = true\n',
        [(
            "inputs.a.port and inputs.b.port",
            "both want the same resource (listen on udp 0.0.0.0:10110; listen on udp 127.0.0.1:10110)",
        )],
    ),
    (
        "serial-same-device",
        f'[inputs.a]\n{SERIAL}device = "/dev/ttyUSB0"\n[inputs.b]\n{SERIAL}device = "/dev/ttyUSB0"\nbaudrate = 38400\n',
        [("inputs.a.device and inputs.b.device", "both read serial /dev/ttyUSB0")],
    ),
    (
        "bridge-tcp-and-foxglove-one-port",
        '[outputs.a]\ntype = "nmea0183"\ntransport = "tcp"\nport = 8765\n[outputs.f]\ntype = "foxglove"\n',
        [("outputs.a.port and outputs.f.port", "both listen on tcp 127.0.0.1:8765")],
    ),
    (
        "bridge-serial-on-an-inputs-device",
        f'[inputs.a]\n{SERIAL}device = "/dev/ttyUSB0"\n[outputs.b]\ntype = "signalk"\ntransport = "serial"\n'
        'device = "/dev/ttyUSB0"\n',
        [("inputs.a.device and outputs.b.device", "both want the same resource (read serial /dev/ttyUSB0; "
          "write serial /dev/ttyUSB0)")],
    ),
    (
        "zenoh-and-nmea-udp",
        f'[inputs.a]\n{UDP}port = 7447\n[outputs.z]\n{ZOUT}listen = ["udp/127.0.0.1:7447"]\n',
        [("inputs.a.port and outputs.z.listen.0", "both want the same resource")],
    ),
    (
        "zenoh-tcp-and-tls",
        f'[inputs.zi]\ntype = "zenoh"\nlisten = ["tls/0.0.0.0:7447"]\n'
        f'[outputs.z]\n{ZOUT}listen = ["tcp/127.0.0.1:7447"]\n',
        [("inputs.zi.listen.0 and outputs.z.listen.0", "both want the same resource")],
    ),
    (
        "name-two-roles",
        f"[inputs.rec]\n{TCP}\nMCAP",
        [("inputs.rec and outputs.rec", "the name 'rec' is used twice")],
    ),
]


def _text(template: str, tmp: Path) -> str:
    return template.replace("MCAP", mcap(tmp)).replace("TMP", str(tmp))


@pytest.fixture
def no_start(monkeypatch):
    """`run` must stop at the configuration: building the runtime fails the test."""

    def _refuse(*args, **kwargs):
        raise AssertionError("edged run started a runtime with a bad configuration")

    monkeypatch.setattr(edged.commands, "Runtime", _refuse)  # check-config
    monkeypatch.setattr(edged.runcmd, "Runtime", _refuse)  # run


@pytest.mark.parametrize("name, template, expected", BAD, ids=[b[0] for b in BAD])
def test_check_config_and_run_refuse_alike(tmp_path, capsys, no_start, name, template, expected):
    path = tmp_path / "edged.toml"
    path.write_text(_text(template, tmp_path))

    assert main(["check-config", str(path)]) == 2
    checked = capsys.readouterr()
    assert main(["run", "-c", str(path)]) == 2
    ran = capsys.readouterr()

    assert checked.err == ran.err
    assert "Traceback" not in checked.err + checked.out + ran.err + ran.out
    assert not (tmp_path / "rec").exists()  # nothing started, nothing created
    for key, reason in expected:
        reason = reason.replace("TMP", str(tmp_path))
        line = next((ln for ln in checked.err.splitlines() if ln.startswith(f"{path}: {key}: ")), None)
        assert line is not None, (key, checked.err)
        assert reason in line, (reason, line)


GOOD: list[tuple[str, str]] = [
    ("udp-two-ports", f"[inputs.a]\n{UDP}port = 10110\n[inputs.b]\n{UDP}port = 10111\n"),
    ("udp-two-addresses", f'[inputs.a]\n{UDP}port = 10110\n[inputs.b]\n{UDP}port = 10110\nbind = "127.0.0.2"\n'),
    ("udp-one-disabled", f"[inputs.a]\n{UDP}port = 10110\n[inputs.b]\n{UDP}port = 10110\nenabled = false\n"),
    ("tcp-one-server-two-clients", f"[inputs.a]\n{TCP}[inputs.b]\n{TCP}"),
    ("serial-urls", f'[inputs.a]\n{SERIAL}device = "loop://"\n[inputs.b]\n{SERIAL}device = "loop://"\n'),
    ("can-two-on-one-bus", f'[inputs.a]\n{CAN}channel = "bus0"\n[inputs.b]\n{CAN}channel = "bus0"\n'),
    (
        "zenoh-port-0",
        f'[inputs.zi]\ntype = "zenoh"\nlisten = ["tcp/127.0.0.1:0"]\n[outputs.z]\n{ZOUT}listen = ["tcp/127.0.0.1:0"]\n',
    ),
    ("log-file-in-a-folder", '[edged]\nlog_file = "TMP/edged.log"\n'),
    ("can-names", f'[inputs.c]\n{CAN}[inputs.c.source_names]\n28 = "gyro-2.aft_1"\n'),
    ("bounds-inclusive", "[edged]\nshutdown_timeout = 600\nhealth_interval = 3600\nMCAP queue_size = 10000000\n"),
]


@pytest.mark.parametrize("name, template", GOOD, ids=[g[0] for g in GOOD])
def test_what_may_share_still_loads(tmp_path, capsys, name, template):
    path = tmp_path / "edged.toml"
    path.write_text(_text(template, tmp_path))
    assert main(["check-config", str(path)]) == 0, capsys.readouterr().err


def test_serial_device_through_a_symlink_is_the_same_device(tmp_path, capsys, no_start):
    dev = tmp_path / "ttyUSB0"
    dev.write_bytes(b"")
    link = tmp_path / "by-id-gnss"
    link.symlink_to(dev)
    path = tmp_path / "edged.toml"
    path.write_text(f'[inputs.a]\n{SERIAL}device = "{dev}"\n[inputs.b]\n{SERIAL}device = "{link}"\n')
    assert main(["check-config", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}: inputs.a.device and inputs.b.device: both want the same resource" in err
    assert main(["run", "-c", str(path)]) == 2
    assert capsys.readouterr().err == err


def test_deploy_example_claims_nothing_twice():
    """The shipped example holds a UDP input, a serial one and a zenoh peer: all apart."""
    load_config(REPO / "deploy" / "edged.toml", Registry())


# -- the core knows no transport: claims are the plugin's, collisions the core's ----
def _registry() -> Registry:
    from edged.plugin import Claim  # here: the module's other tests run on any core

    class _PortConfig(InputConfig):
        where: str = "*"
        port: int = 1

        def claims(self) -> list[Claim]:
            return [Claim("port", ("thing", self.where, str(self.port)), f"hold thing {self.where}:{self.port}")]

    class _PortInput(InputPlugin):
        Config = _PortConfig

    class _Out(OutputPlugin):
        Config = OutputConfig

    r = Registry(use_entry_points=False)
    r.register("inputs", "port", _PortInput)
    r.register("outputs", "out", _Out)
    return r


def test_claims_are_compared_generically_and_all_reported():
    data = {
        "inputs": {
            "a": {"type": "port", "where": "x", "port": 1},
            "b": {"type": "port", "where": "x", "port": 1},
            "c": {"type": "port", "where": "*", "port": 2},
            "d": {"type": "port", "where": "y", "port": 2},
            "e": {"type": "port", "where": "y", "port": 3},
            "f": {"type": "port", "where": "z", "port": 3},
        },
        "outputs": {"a": {"type": "out"}},
    }
    with pytest.raises(ConfigError) as ei:
        parse_config(data, _registry(), file="t.toml")
    assert ei.value.errors == [
        ("inputs.a and outputs.a", ei.value.errors[0][1]),
        ("inputs.a.port and inputs.b.port", "both hold thing x:1"),
        ("inputs.c.port and inputs.d.port", "both want the same resource (hold thing *:2; hold thing y:2)"),
    ]
    assert "the name 'a' is used twice" in ei.value.errors[0][1]


def test_default_claims_are_none():
    assert OutputConfig(type="x").claims() == []
    assert InputConfig(type="x").claims() == []


# -- Backoff itself ---------------------------------------------------------------
@pytest.mark.parametrize(
    "initial, maximum, factor",
    [(math.inf, math.inf, 2.0), (0.5, math.inf, 2.0), (math.nan, 30.0, 2.0), (0.5, math.nan, 2.0), (0.5, 30.0, math.inf)],
)
def test_backoff_refuses_non_finite(initial, maximum, factor):
    with pytest.raises(ValueError, match="finite"):
        Backoff(initial, maximum, factor)


def test_backoff_still_doubles_up_to_its_maximum():
    b = Backoff(0.5, 2.0)
    assert [b.next_delay() for _ in range(4)] == [0.5, 1.0, 2.0, 2.0]


def test_a_bridge_output_naming_an_estimator_that_is_not_configured_is_refused(tmp_path, capsys):
    """`stw = "stw2"` with no [estimators.stw2]: a configuration error naming the key,
    not an output that never sends; a default role left unfilled (no draft) is fine."""
    from edged.cli import main

    bad = tmp_path / "bad.toml"
    bad.write_text('[estimators.stw]\ntype = "stw"\n[outputs.b]\ntype = "nmea0183"\nstw = "stw2"\n')
    assert main(["check-config", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "outputs.b" in err and "stw = 'stw2' names no estimator instance (configured: stw)" in err
    good = tmp_path / "good.toml"
    good.write_text('[estimators.stw]\ntype = "stw"\n[outputs.b]\ntype = "nmea0183"\n')
    assert main(["check-config", str(good)]) == 0
