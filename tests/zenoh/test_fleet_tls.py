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

import contextlib
import itertools
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator

import json5
import pytest
import zenoh

from edged.registry import Registry

REPO = Path(__file__).resolve().parents[2]
SHIPPED = REPO / "deploy" / "zenoh" / "router-tls.json5"
MAKE_CERTS = REPO / "deploy" / "zenoh" / "make-test-certs.sh"
PYTHON = sys.executable
WAIT = 45.0  # seconds: a safety net on a loaded machine, never the synchronisation itself
VESSELS = ("vessel-1", "vessel-2", "vessel-3")
DASHBOARD = "fleet-dashboard"
ROGUES = ("fleet-dashboard", "vessel-1")  # the same common names, signed by another CA
#: Seconds of the simulated voyage each daemon replays in real time: longer than this
#: file runs, and the daemons end by themselves should a test run leave them behind.
VOYAGE_S = 240


# -- a throwaway PKI ------------------------------------------------------------------
class Pki:
    """The site's CA (ca.pem), the router's certificate for 127.0.0.1, one client
    certificate per vessel and the dashboard (common name = name), and in `other/` a
    second CA's certificates for the same names."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.ca = str(folder / "ca.pem")

    def cert(self, name: str, *, other: bool = False) -> str:
        return str((self.folder / "other" if other else self.folder) / f"{name}.pem")

    def key(self, name: str, *, other: bool = False) -> str:
        return str((self.folder / "other" if other else self.folder) / f"{name}.key")

    def client_tls(self, name: str, *, other: bool = False) -> dict[str, Any]:
        return {"root_ca_certificate": self.ca, "connect_certificate": self.cert(name, other=other),
                "connect_private_key": self.key(name, other=other), "enable_mtls": True}


@pytest.fixture(scope="module")
def pki(tmp_path_factory: pytest.TempPathFactory) -> Pki:
    """Made by deploy/zenoh/make-test-certs.sh, as a user makes them. Skipped only where
    openssl is not installed (as test_router_acl.py)."""
    if shutil.which("openssl") is None:
        pytest.skip("cannot make TLS certificates: openssl is not installed")
    p = Pki(tmp_path_factory.mktemp("pki"))
    subprocess.run(["sh", str(MAKE_CERTS), str(p.folder), *VESSELS, DASHBOARD], check=True, capture_output=True,
                   timeout=120)
    subprocess.run(["sh", str(MAKE_CERTS), str(p.folder / "other"), *ROGUES], check=True, capture_output=True,
                   env={**os.environ, "CA_NAME": "some other CA"}, timeout=120)
    return p


# -- the router's configuration --------------------------------------------------------
def add_vessel(acl: dict[str, Any], vessel: str, like: str = "vessel-1") -> None:
    """deploy/zenoh/README.md: "Add a vessel to router-tls.json5 by copying one vessel's
    five rules with its id replaced, adding a subject with its certificate's common name
    and a policy joining them to `vessels-see-readers`." Done on the parsed file."""

    def swap(value: Any) -> Any:
        if isinstance(value, str):
            return value.replace(like, vessel)
        if isinstance(value, list):
            return [swap(v) for v in value]
        if isinstance(value, dict):
            return {k: swap(v) for k, v in value.items()}
        return value

    own = [r for r in acl["rules"] if r["id"].startswith(f"{like}-")]
    assert len(own) == 5, f"{like}'s rules are not five: {[r['id'] for r in own]}"
    new = [swap(r) for r in own]
    assert not {r["id"] for r in new} & {r["id"] for r in acl["rules"]}
    acl["rules"].extend(new)
    (subject,) = [s for s in acl["subjects"] if like in s.get("cert_common_names", [])]
    acl["subjects"].append({"id": vessel, "cert_common_names": [vessel]})
    (policy,) = [p for p in acl["policies"] if subject["id"] in p["subjects"]]
    shared = [rid for rid in policy["rules"] if not rid.startswith(f"{like}-")]
    assert shared == ["vessels-see-readers"], shared
    acl["policies"].append({"rules": [r["id"] for r in new] + shared, "subjects": [vessel]})


def router_config(pki: Pki, endpoint: str, path: Path, *, acl: bool) -> Path:
    """The shipped file with its certificate paths and listen endpoint replaced, and
    vessel-3 added to its access control (switched off when not `acl`)."""
    cfg = json5.loads(SHIPPED.read_text())
    tls = cfg["transport"]["link"]["tls"]
    assert set(tls) >= {"root_ca_certificate", "listen_certificate", "listen_private_key"}
    tls.update(root_ca_certificate=pki.ca, listen_certificate=pki.cert("router"),
               listen_private_key=pki.key("router"))
    cfg["listen"]["endpoints"] = [endpoint]
    add_vessel(cfg["access_control"], "vessel-3")
    cfg["access_control"]["enabled"] = acl
    path.write_text(json.dumps(cfg, indent=2))
    return path


def client_file(pki: Pki, endpoint: str, name: str, path: Path, *, other: bool = False) -> Path:
    """A `--zenoh-config` file: a client of the router with `name`'s certificate."""
    path.write_text(json.dumps({
        "mode": "client",
        "connect": {"endpoints": [endpoint]},
        "listen": {"endpoints": []},
        "transport": {"link": {"tls": pki.client_tls(name, other=other)}},
    }, indent=2))
    return path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# -- child processes ------------------------------------------------------------------
class Child:
    """A command in a process group of its own; its stdout and stderr lines are read by
    threads. `stop` signals the whole group."""

    def __init__(self, argv: list[str]) -> None:
        self.argv = argv
        self.proc = subprocess.Popen(
            argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO,
            env=dict(os.environ, PYTHONUNBUFFERED="1"), start_new_session=True,
        )
        self.out: list[str] = []
        self.err: list[str] = []
        self.ended = 0
        self._cv = threading.Condition()
        for stream, lines in ((self.proc.stdout, self.out), (self.proc.stderr, self.err)):
            threading.Thread(target=self._pump, args=(stream, lines), daemon=True).start()

    def _pump(self, stream: Any, lines: list[str]) -> None:
        for line in stream:
            with self._cv:
                lines.append(line.rstrip("\n"))
                self._cv.notify_all()
        with self._cv:
            self.ended += 1
            self._cv.notify_all()

    def wait_until(self, done: Callable[[list[str]], bool], what: str) -> None:
        """Until `done(stdout lines so far)`; fails if the process ends first."""
        with self._cv:
            ok = self._cv.wait_for(lambda: done(self.out) or self.ended == 2, WAIT)
            if not (ok and done(self.out)):
                raise AssertionError(f"{what}: not seen (process {'ended' if self.ended == 2 else 'running'})\n"
                                     f"{self.tail()}")

    def tail(self) -> str:
        return (f"$ {' '.join(self.argv)}\nstdout: {self.out[-15:]}\nstderr: {self.err[-15:]}")

    def stop(self) -> int:
        """SIGTERM to the group, then SIGKILL to whatever of it is left; the exit code."""
        pgid = self.proc.pid  # the leader of its own group (start_new_session)
        if self.proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(pgid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                pass
        with contextlib.suppress(ProcessLookupError):
            os.killpg(pgid, 0)  # raises once the group is empty
            os.killpg(pgid, signal.SIGKILL)
        return self.proc.wait(timeout=20)


def start_router(config: Path) -> Child:
    router = Child([PYTHON, "-m", "edged.cli", "router", "--zenoh-config", str(config)])
    try:
        router.wait_until(lambda lines: any("listening on" in ln for ln in lines), "edged router listening")
    except BaseException:
        router.stop()
        raise
    return router


# -- zenoh sessions ---------------------------------------------------------------------
def tls_session(pki: Pki, endpoint: str, name: str, *, other: bool = False) -> zenoh.Session:
    """A client session over TLS with the certificate `name`, no scouting."""
    cfg = zenoh.Config()
    for key, value in {
        "mode": "client",
        "connect/endpoints": [endpoint],
        "listen/endpoints": [],
        "scouting/multicast/enabled": False,
        "scouting/gossip/enabled": False,
        "transport/link/tls": pki.client_tls(name, other=other),
    }.items():
        cfg.insert_json5(key, json.dumps(value))
    return zenoh.open(cfg)


class Seen:
    """(key, kind, payload) of every sample a callback got, in arrival order and as a set
    (the fleet sends hundreds a second); zenoh calls it on its threads."""

    def __init__(self) -> None:
        self.items: list[tuple[str, str, str]] = []
        self._index: set[tuple[str, str, str]] = set()
        self._cv = threading.Condition()

    def __call__(self, sample: zenoh.Sample) -> None:
        kind = "put" if sample.kind == zenoh.SampleKind.PUT else "delete"
        item = (str(sample.key_expr), kind, sample.payload.to_bytes().decode(errors="replace"))
        with self._cv:
            self.items.append(item)
            self._index.add(item)
            self._cv.notify_all()

    def snapshot(self) -> list[tuple[str, str, str]]:
        with self._cv:
            return list(self.items)

    def has(self, key: str, payload: str, kind: str = "put") -> bool:
        with self._cv:
            return (key, kind, payload) in self._index

    def wait_for(self, done: Callable[[list[tuple[str, str, str]]], bool], what: str,
                 context: Callable[[], str] = lambda: "") -> None:
        """Until `done(items)` (called with the lock held, at each new sample)."""
        with self._cv:
            if not self._cv.wait_for(lambda: done(self.items), WAIT):
                raise AssertionError(f"never arrived: {what}; last seen {self.items[-5:]}\n{context()}")

    def wait(self, key: str, payload: str, kind: str = "put") -> None:
        item = (key, kind, payload)
        self.wait_for(lambda _: item in self._index, str(item))


def wait_matching(pub: zenoh.Publisher) -> None:
    """Until the router has told the publisher of a matching subscriber."""
    matched = threading.Event()
    listener = pub.declare_matching_listener(lambda st: matched.set() if st.matching else None)
    try:
        if not pub.matching_status.matching:
            assert matched.wait(WAIT), f"no subscriber ever matched {pub.key_expr}"
    finally:
        listener.undeclare()


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


def _net(pki: Pki, folder: Path, *, acl: bool) -> Iterator[Net]:
    endpoint = f"tls/127.0.0.1:{free_port()}"
    router = start_router(router_config(pki, endpoint, folder / "router.json5", acl=acl))
    try:
        net = Net(pki, endpoint)
        try:
            yield net
        finally:
            net.close()
    finally:
        router.stop()


@pytest.fixture(scope="module")
def acl_net(pki: Pki, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Net]:
    """The shipped access control, vessel-3 added."""
    yield from _net(pki, tmp_path_factory.mktemp("acl"), acl=True)


@pytest.fixture(scope="module")
def open_net(pki: Pki, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Net]:
    """The same file with access control switched off: the probes' own check."""
    yield from _net(pki, tmp_path_factory.mktemp("open"), acl=False)


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
    if missing:
        pytest.skip(f"not installed: {missing}")
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
