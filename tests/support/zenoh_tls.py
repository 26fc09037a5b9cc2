"""The TLS fleet's test kit: a throwaway PKI, the shore router, child processes, sessions.

Shared by test_fleet_tls.py (three daemons behind the shore router),
test_ship_to_shore.py (a ship's router linked to it) and test_router_acl.py (the shipped
access control, rule by rule): one definition of each, imported from here
(`tests/support` is on pytest's path) rather than one test module loading another by
its path.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any, Callable, Iterator, Protocol, Sequence, TypeVar

import json5
import pytest
import zenoh

REPO = Path(__file__).resolve().parents[2]
SHIPPED = REPO / "deploy" / "zenoh" / "router-tls.json5"
MAKE_CERTS = REPO / "deploy" / "zenoh" / "make-test-certs.sh"
PYTHON = sys.executable
WAIT = 45.0  # seconds: a safety net on a loaded machine, never the synchronisation itself
VESSELS = ("vessel-1", "vessel-2", "vessel-3")
DASHBOARD = "fleet-dashboard"
ROGUES = ("fleet-dashboard", "vessel-1")  # the same common names, signed by another CA


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
    openssl is not installed."""
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


def router_config(pki: Pki, endpoint: str, path: Path, *, acl: bool,
                  extra_vessels: Sequence[str] = ("vessel-3",)) -> Path:
    """The shipped file with its certificate paths and listen endpoint replaced, and
    `extra_vessels` added to its access control (switched off when not `acl`); with
    `extra_vessels=()` its access control is the shipped one."""
    cfg = json5.loads(SHIPPED.read_text())
    tls = cfg["transport"]["link"]["tls"]
    assert set(tls) >= {"root_ca_certificate", "listen_certificate", "listen_private_key"}
    tls.update(root_ca_certificate=pki.ca, listen_certificate=pki.cert("router"),
               listen_private_key=pki.key("router"))
    cfg["listen"]["endpoints"] = [endpoint]
    for vessel in extra_vessels:
        add_vessel(cfg["access_control"], vessel)
    cfg["access_control"]["enabled"] = acl
    path.write_text(json.dumps(cfg, indent=2))
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

    def _matches(self, key: str, payload: str | None, kind: str | None) -> bool:
        """With the lock held. A `payload` or `kind` of None matches any."""
        if payload is not None and kind is not None:
            return (key, kind, payload) in self._index
        return any(k == key and (kind is None or s == kind) and (payload is None or p == payload)
                   for k, s, p in self.items)

    def has(self, key: str, payload: str | None = None, kind: str | None = "put") -> bool:
        """Whether such a sample came; `payload=None` / `kind=None`: any payload / kind."""
        with self._cv:
            return self._matches(key, payload, kind)

    def wait_for(self, done: Callable[[list[tuple[str, str, str]]], bool], what: str,
                 context: Callable[[], str] = lambda: "") -> None:
        """Until `done(items)` (called with the lock held, at each new sample)."""
        with self._cv:
            if not self._cv.wait_for(lambda: done(self.items), WAIT):
                raise AssertionError(f"never arrived: {what}; last seen {self.items[-5:]}\n{context()}")

    def wait(self, key: str, payload: str | None = None, kind: str | None = "put") -> None:
        """Until `has(key, payload, kind)`."""
        self.wait_for(lambda _: self._matches(key, payload, kind), str((key, kind, payload)))


def wait_matching(pub: zenoh.Publisher) -> None:
    """Until the router has told the publisher of a matching subscriber."""
    matched = threading.Event()
    listener = pub.declare_matching_listener(lambda st: matched.set() if st.matching else None)
    try:
        if not pub.matching_status.matching:
            assert matched.wait(WAIT), f"no subscriber ever matched {pub.key_expr}"
    finally:
        listener.undeclare()


# -- the shore router and a test module's sessions -------------------------------------------
class _Closable(Protocol):
    def close(self) -> None: ...


N = TypeVar("N", bound=_Closable)


def serve_net(pki: Pki, folder: Path, make_net: Callable[[Pki, str], N], *, acl: bool,
              extra_vessels: Sequence[str] = ("vessel-3",)) -> Iterator[N]:
    """For a module-scoped fixture: the shore router (`router_config` in `folder`) on a
    free port, and `make_net(pki, endpoint)` (a test module's sessions); it yields those,
    then closes them and stops the router."""
    endpoint = f"tls/127.0.0.1:{free_port()}"
    router = start_router(router_config(pki, endpoint, folder / "router.json5", acl=acl,
                                        extra_vessels=extra_vessels))
    try:
        net = make_net(pki, endpoint)
        try:
            yield net
        finally:
            net.close()
    finally:
        router.stop()
