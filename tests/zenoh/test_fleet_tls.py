"""A fleet behind the shore router (issue 16): three edged daemons over mutual TLS.

`edged router` runs deploy/zenoh/router-tls.json5 with only its certificate paths and
its listen endpoint replaced (TLS on 127.0.0.1, a free port), and a third vessel added
to the test's copy of its access control the way deploy/zenoh/README.md says: one
vessel's five rules copied with its id replaced, a subject with the new certificate's
common name, and a policy joining them to `vessels-see-readers`. Three edged daemons are
its clients as `vessel-1`, `vessel-2` and `vessel-3`, each with its own certificate made
by deploy/zenoh/make-test-certs.sh: `edged replay --speed 1` of the NMEA 0183 log of a
voyage simulated by `edged sim demo` (GNSS, gyro, log...: the STW and manoeuvring
estimators run on it in real time; the daemons stay light, as the rest of a parallel
test run needs). Shown:

1. a shore session with the `fleet-dashboard` certificate receives every vessel's
   estimates, and its queries are answered by every vessel's daemon; `edged fleet` with
   that certificate lists the three vessels;
2. a certificate of another CA opens no session (a zenoh session, and `edged fleet`);
3. a vessel's puts under another vessel's prefix, and the shore's outside
   `vessel/*/env/current`, never arrive; the same probes through the same file with
   access control off do arrive (a probe that could see nothing proves nothing).

"Never arrives" as in test_router_acl.py, without waiting for a while: the forbidden
puts are followed by an allowed put of the same session, and once that has reached
the shore's subscriber (one session's messages are handled by the router in the order
sent, and one link delivers them to one subscriber in order) the forbidden ones are
looked for. The forbidden puts are plain `session.put`s (sent whatever the session
knows of subscribers), so it is the router that drops them.
"""

from __future__ import annotations

import itertools
import json
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator

import pytest
import zenoh

from edged.registry import Registry
from zenoh_tls import pki  # noqa: F401 (the fixture)
from zenoh_tls import (DASHBOARD, PYTHON, REPO, ROGUES, VESSELS, WAIT, Child, Pki, Seen, serve_net, tls_session,
                       wait_matching)

#: Seconds of the simulated voyage each daemon replays in real time: longer than this
#: file runs, and the daemons end by themselves should a test run leave them behind.
VOYAGE_S = 240


# -- the clients' configuration ------------------------------------------------------
def client_file(pki: Pki, endpoint: str, name: str, path: Path, *, other: bool = False) -> Path:
    """A `--zenoh-config` file: a client of the router with `name`'s certificate."""
    path.write_text(json.dumps({
        "mode": "client",
        "connect": {"endpoints": [endpoint]},
        "listen": {"endpoints": []},
        "transport": {"link": {"tls": pki.client_tls(name, other=other)}},
    }, indent=2))
    return path


_tags = itertools.count()


def tag(what: str) -> str:
    return json.dumps({"probe": f"{what}-{next(_tags)}"})


class Net:
    """The router and the test's own sessions: `watch` (the shore, subscribed to
    `vessel/**` and its liveliness), `ask` (the shore asking: gets), `shore` (the shore
    acting: puts) and one session per vessel certificate (a vessel acting)."""

    ROLES = {"watch": DASHBOARD, "ask": DASHBOARD, "shore": DASHBOARD, **{v: v for v in VESSELS}}

    def __init__(self, pki: Pki, endpoint: str) -> None:
        self.endpoint = endpoint
        self.s: dict[str, zenoh.Session] = {}
        self.keep: list[Any] = []
        self.data, self.alive = Seen(), Seen()
        try:
            for role, cert in self.ROLES.items():
                self.s[role] = tls_session(pki, endpoint, cert)
            watch = self.s["watch"]
            self.keep += [watch.liveliness().declare_subscriber("vessel/**", self.alive, history=True),
                          watch.declare_subscriber("vessel/**", self.data)]
            ready = self.s["vessel-1"].declare_publisher("vessel/vessel-1/est/ready")
            wait_matching(ready)  # watch's declarations (one link, in order) are at the router
            ready.undeclare()
            for role in ("shore", *VESSELS):
                self.sync(role)
        except BaseException:
            self.close()
            raise

    def sync(self, who: str) -> None:
        """An allowed put of `who` seen by `watch`: whatever `who` sent before is handled."""
        key = "vessel/vessel-3/env/current" if who == "shore" else f"vessel/{who}/est/probe"
        marker = tag(f"sync-{who}")
        self.s[who].put(key, marker)
        self.data.wait(key=key, payload=marker)

    def close(self) -> None:
        for d in self.keep:
            d.undeclare()
        for s in self.s.values():
            s.close()


@pytest.fixture(scope="module")
def acl_net(pki: Pki, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Net]:
    """The shipped access control, vessel-3 added."""
    yield from serve_net(pki, tmp_path_factory.mktemp("acl"), Net, acl=True)


@pytest.fixture(scope="module")
def open_net(pki: Pki, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Net]:
    """The same file with access control switched off: the probes' own check."""
    yield from serve_net(pki, tmp_path_factory.mktemp("open"), Net, acl=False)


# -- the fleet: three edged daemons -------------------------------------------------------
def _est_times(items: list[tuple[str, str, str]], vessel: str) -> set[float]:
    """Data times of the daemon's estimates of `vessel` seen (the test's probes left out)."""
    out = set()
    prefix = f"vessel/{vessel}/est/"
    for key, kind, payload in items:
        if kind == "put" and key.startswith(prefix) and key not in (prefix + "probe", prefix + "ready"):
            out.add(json.loads(payload)["t"])
    return out


def estimates_of(vessel: str, times: int) -> Callable[[list[tuple[str, str, str]]], bool]:
    """A `Seen.wait_for` condition: estimates of `times` data times from `vessel`'s daemon
    (each call reads only the samples that came since the last)."""
    seen: set[float] = set()
    read = 0

    def done(items: list[tuple[str, str, str]]) -> bool:
        nonlocal read
        seen.update(_est_times(items[read:], vessel))
        read = len(items)
        return len(seen) >= times

    return done


@dataclass
class Fleet:
    net: Net
    daemons: dict[str, Child]

    def running(self) -> None:
        for vessel, d in self.daemons.items():
            assert d.proc.poll() is None, f"{vessel}'s daemon ended\n{d.tail()}"


@pytest.fixture(scope="module")
def fleet(pki: Pki, acl_net: Net, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Fleet]:
    """`edged replay --speed 1` of a simulated voyage as vessel-1, vessel-2 and vessel-3,
    each a client of the router with its own certificate; ready once the shore holds each
    one's liveliness token (declared after its queryable) and has seen estimates of three
    data times from each (so that what was published is in its latest values, which a
    query answers with)."""
    needed = {"commands": {"sim", "router", "fleet"}, "inputs": {"nmea0183"}, "estimators": {"stw", "manoeuvre"}}
    registry = Registry()
    missing = sorted(f"{role}:{name}" for role, names in needed.items() for name in names - set(registry.names(role)))
    assert not missing, f"first-party plugins not installed (a broken install: pip install -e .): {missing}"
    folder = tmp_path_factory.mktemp("fleet")
    subprocess.run([PYTHON, "-m", "edged.cli", "sim", "demo", "--out", str(folder / "sim"), "--duration", str(VOYAGE_S)],
                   check=True, capture_output=True, cwd=REPO, timeout=120)
    log = folder / "sim" / "nmea.log"
    daemons: dict[str, Child] = {}
    try:
        for vessel in VESSELS:
            zcfg = client_file(pki, acl_net.endpoint, vessel, folder / f"{vessel}.json5")
            daemons[vessel] = Child([
                PYTHON, "-m", "edged.cli", "replay", str(log), "--speed", "1", "--no-progress",
                "--vessel-id", vessel, "--zenoh-config", str(zcfg),
            ])
        for vessel, d in daemons.items():
            token = (f"vessel/{vessel}/alive", "put", "")
            acl_net.alive.wait_for(lambda items, t=token: t in items, f"{vessel}'s liveliness token", d.tail)
            acl_net.data.wait_for(estimates_of(vessel, 3), f"{vessel}'s estimates", d.tail)
        yield Fleet(acl_net, daemons)
    finally:
        for d in daemons.values():
            d.stop()


def _replies(session: zenoh.Session, selector: str) -> list[tuple[str, str]]:
    """Every reply to a get; it returns once every queryable the router reached is done."""
    return [(str(r.ok.key_expr), r.ok.payload.to_string()) for r in session.get(selector, timeout=WAIT)
            if r.ok is not None]


# -- 1. the shore sees and queries every vessel -----------------------------------------------
def test_shore_receives_every_vessels_estimates_and_queries_them(fleet: Fleet) -> None:
    net, seen = fleet.net, fleet.net.data.snapshot()
    for vessel in VESSELS:
        prefix = f"vessel/{vessel}/est/"
        est = {k for k, kind, _ in seen if kind == "put" and k.startswith(prefix) and k != prefix + "probe"}
        assert est and est <= {prefix + n for n in ("stw", "manoeuvre", "draft")}, est
        for key, _, payload in seen:
            if key in est:
                obj = json.loads(payload)
                assert {"t", "kind", "stale", "age", "converging"} <= set(obj), (key, obj)

        # The daemon's queryable answers with its latest value of each key, its own only.
        replies = dict(_replies(net.s["ask"], f"vessel/{vessel}/**"))
        assert all(k.startswith(f"vessel/{vessel}/") for k in replies), sorted(replies)
        answered = {k for k in replies if k.startswith(prefix)}
        assert answered, f"{vessel} answered no estimate: {sorted(replies)}"
        first = min(_est_times(seen, vessel))
        for key in answered:
            assert json.loads(replies[key])["t"] >= first, (key, replies[key])

    # One get across the fleet is answered by every vessel; the router holds three tokens.
    fleet_replies = _replies(net.s["ask"], "vessel/*/est/**")
    assert {k.split("/")[1] for k, _ in fleet_replies} == set(VESSELS), sorted(k for k, _ in fleet_replies)
    tokens = {str(r.ok.key_expr) for r in net.s["ask"].liveliness().get("vessel/*/alive", timeout=WAIT)
              if r.ok is not None}
    assert tokens == {f"vessel/{v}/alive" for v in VESSELS}
    fleet.running()


def test_edged_fleet_lists_the_three_vessels(fleet: Fleet, pki: Pki, tmp_path: Path) -> None:
    """`edged fleet` with the dashboard's certificate: a row per vessel, with the position
    of its manoeuvring estimate; stopped by SIGTERM, as systemd or Ctrl-C stop it."""
    cfg = client_file(pki, fleet.net.endpoint, DASHBOARD, tmp_path / "dashboard.json5")
    cli = Child([PYTHON, "-m", "edged.cli", "fleet", "--zenoh-config", str(cfg)])
    rows: dict[str, list[str]] = {}

    def listed(lines: list[str]) -> bool:
        for line in lines:  # the table, redrawn every second: the latest row of each vessel
            cols = line.split()  # VESSEL, LAST SEEN (n s), STW, HDG, LAT, LON, STATE ...
            if len(cols) >= 8 and cols[0] in VESSELS and cols[2] == "s":
                rows[cols[0]] = cols
        return all(v in rows and rows[v][5] != "-" and rows[v][7] not in ("offline", "stale") for v in VESSELS)

    try:
        cli.wait_until(listed, "a row with a position for each of vessel-1, vessel-2, vessel-3")
    finally:
        rc = cli.stop()
    assert rc == 0, cli.tail()
    for vessel in VESSELS:
        lat, lon = float(rows[vessel][5]), float(rows[vessel][6])
        assert -90 <= lat <= 90 and -180 <= lon <= 180, rows[vessel]
    assert set(rows) == set(VESSELS), rows
    fleet.running()


# -- 2. another CA's certificate is refused ------------------------------------------------
# While the fleet publishes: a session that cannot open gets none of it.
@pytest.mark.parametrize("name", ROGUES)
def test_a_certificate_of_another_ca_opens_no_session(fleet: Fleet, pki: Pki, name: str) -> None:
    with pytest.raises(zenoh.ZError, match="Unable to connect"):
        tls_session(pki, fleet.net.endpoint, name, other=True).close()


def test_edged_fleet_with_another_cas_certificate_is_refused(fleet: Fleet, pki: Pki, tmp_path: Path) -> None:
    cfg = client_file(pki, fleet.net.endpoint, DASHBOARD, tmp_path / "rogue.json5", other=True)
    cli = Child([PYTHON, "-m", "edged.cli", "fleet", "--zenoh-config", str(cfg)])
    try:
        rc = cli.proc.wait(timeout=WAIT)
        cli.wait_until(lambda _: cli.ended == 2, "the end of its output")
    finally:
        cli.stop()
    assert rc == 1, cli.tail()
    assert not any(ln.startswith(VESSELS) for ln in cli.out), cli.tail()
    assert any(ln.startswith("edged fleet: ") and "Unable to connect" in ln for ln in cli.err), cli.tail()
    fleet.running()


# -- 3. forbidden puts never arrive -----------------------------------------------------------
#: who puts (a session with that certificate), and on which keys
FORBIDDEN: dict[str, tuple[str, list[str]]] = {
    "vessel-3-publishes-as-vessel-1-and-vessel-2": ("vessel-3", [
        "vessel/vessel-1/est/stw", "vessel/vessel-1/est/manoeuvre", "vessel/vessel-1/health",
        "vessel/vessel-2/est/draft", "vessel/vessel-2/meas/heading/gyro", "vessel/vessel-2/alive",
    ]),
    "vessel-1-publishes-as-vessel-3": ("vessel-1", [
        "vessel/vessel-3/est/stw", "vessel/vessel-3/health", "vessel/vessel-3/meas/position/gnss1",
    ]),
    "vessel-3-forges-its-own-forecast": ("vessel-3", ["vessel/vessel-3/env/current"]),
    "shore-publishes-outside-forecasts": ("shore", [
        "vessel/vessel-1/est/stw", "vessel/vessel-2/health", "vessel/vessel-3/meas/heading/gyro",
        "vessel/vessel-3/alive", "vessel/vessel-3/est/manoeuvre", "vessel/vessel-2/env/other",
    ]),
}


def forbidden_puts(net: Net, case: str) -> list[str]:
    """The keys of the case whose forged put reached the shore's subscriber."""
    who, keys = FORBIDDEN[case]
    forged = tag(f"forged-{case}")
    for key in keys:
        net.s[who].put(key, forged)
    net.sync(who)  # after them on the same session: once seen, the router has handled them
    return [k for k in keys if net.data.has(key=k, payload=forged)]


@pytest.mark.parametrize("case", list(FORBIDDEN))
def test_forbidden_puts_never_arrive(fleet: Fleet, case: str) -> None:
    """While the three daemons publish."""
    assert forbidden_puts(fleet.net, case) == [], f"{case}: arrived through the access control"
    fleet.running()


@pytest.mark.parametrize("case", list(FORBIDDEN))
def test_the_probes_see_forbidden_puts_without_access_control(open_net: Net, case: str) -> None:
    assert forbidden_puts(open_net, case) == FORBIDDEN[case][1]
