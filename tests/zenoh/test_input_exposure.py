"""`edged check-config` warns when a zenoh input takes data from other hosts unguarded.

On the loopback endpoint the local processes are trusted (deploy/zenoh/README.md);
beyond it anyone who reaches the endpoint could publish the forecasts the STW estimator
uses. A warning on stderr naming the keys and the endpoint, never an error.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from edged.cli import main
from edged_zenoh.zconfig import safe_defaults, unguarded_endpoints

EVENT = "event=zenoh-input-unguarded"


def _check(tmp_path: Path, table: str, capsys: pytest.CaptureFixture[str]) -> str:
    path = tmp_path / "edged.toml"
    path.write_text('[edged]\nvessel_id = "v7"\n\n[inputs.shore]\ntype = "zenoh"\n' + table)
    assert main(["check-config", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "OK" in out
    return err


def _json5(tmp_path: Path, text: str) -> str:
    p = tmp_path / "z.json5"
    p.write_text(text)
    return f'zenoh_config = "{p}"\n'


@pytest.mark.parametrize(("table", "endpoint"), [
    ('mode = "peer"\nlisten = ["tcp/0.0.0.0:7447"]\n', "tcp/0.0.0.0:7447"),
    ('mode = "peer"\nlisten = ["tcp/[::]:7447"]\n', "tcp/[::]:7447"),
    ('connect = ["tcp/192.168.10.2:7447"]\n', "tcp/192.168.10.2:7447"),
    ('connect = ["udp/gateway.example.org:7447"]\n', "udp/gateway.example.org:7447"),
    # mutual TLS is asked of those who connect, not of a plain tcp endpoint beside it
    ('mode = "peer"\nlisten = ["tls/127.0.0.1:7448", "tcp/10.0.0.5:7447"]\ntls = {enable_mtls = true}\n',
     "tcp/10.0.0.5:7447"),
], ids=["listen-any-ipv4", "listen-any-ipv6", "connect-lan-tcp", "connect-host-udp", "tcp-beside-mtls"])
def test_an_unguarded_network_endpoint_is_a_warning_naming_keys_and_endpoint(tmp_path, capsys, table, endpoint):
    err = _check(tmp_path, table + '\n[[inputs.shore.subscriptions]]\nkey = "ship/echo/*"\nkind = "depth"\n'
                 'source = "echo"\n', capsys)
    (line,) = [ln for ln in err.splitlines() if EVENT in ln]
    assert "level=WARNING" in line and "input=shore" in line
    assert "keys=vessel/v7/env/current,ship/echo/*" in line and f"endpoint={endpoint} " in line


def test_multicast_scouting_is_unguarded_too(tmp_path, capsys):
    err = _check(tmp_path, _json5(tmp_path, "{scouting: {multicast: {enabled: true}}}"), capsys)
    assert [ln for ln in err.splitlines() if EVENT in ln and "endpoint=multicast scouting" in ln]


@pytest.mark.parametrize("table", [
    "",  # the default: a client of the daemon's own tcp/127.0.0.1:7447
    'mode = "peer"\nlisten = ["tcp/127.0.0.1:7447"]\n',
    'mode = "peer"\nlisten = ["tcp/[::1]:7447", "tcp/127.0.0.2:7447"]\nconnect = ["tcp/localhost:7448"]\n',
    'connect = ["tls/shore.example.org:7447"]\n',  # the router it proves to be decides (router-tls.json5)
    'mode = "peer"\nlisten = ["tls/0.0.0.0:7447"]\ntls = {enable_mtls = true}\n',
    'mode = "peer"\nlisten = ["tcp/0.0.0.0:7447"]\ncurrent = false\n',  # takes nothing in
], ids=["default", "listen-loopback", "loopback-v6-127/8-localhost", "connect-tls", "listen-mtls", "no-keys"])
def test_no_warning_on_loopback_or_authenticated_links(tmp_path, capsys, table):
    assert EVENT not in _check(tmp_path, table, capsys)


@pytest.mark.parametrize("guard", [
    "{access_control: {enabled: true, default_permission: 'deny'}}",
    "{transport: {auth: {usrpwd: {dictionary_file: '/etc/edged/zenoh/local-users.txt'}}}}",
], ids=["access-control", "logins"])
def test_no_warning_with_access_control_or_logins(tmp_path, capsys, guard):
    table = 'mode = "peer"\nlisten = ["tcp/0.0.0.0:7447"]\n' + _json5(tmp_path, guard)
    assert EVENT not in _check(tmp_path, table, capsys)


def test_access_control_that_allows_by_default_guards_nothing():
    cfg = safe_defaults(listen=["tcp/0.0.0.0:7447"])
    cfg["access_control"] = {"enabled": True, "default_permission": "allow"}
    assert unguarded_endpoints(cfg) == ["tcp/0.0.0.0:7447"]
    assert unguarded_endpoints(safe_defaults(listen=["unixsock-stream//run/edged.sock"])) == []
