"""The shore router's access control (deploy/zenoh/router-tls.json5) on a real router.

`edged router` runs the shipped file with only its certificate paths and its listen
endpoint replaced (mutual TLS on 127.0.0.1), and client sessions connect with the
certificates of a throwaway CA whose common names are `vessel-1`, `vessel-2` and
`fleet-dashboard`. Every allowed flow is shown to work, every forbidden one never to
arrive, and edged's own output and `edged fleet` to work through it.

"Never arrives" without waiting for a while: the forbidden action is followed by an
allowed one on the same session, and once the allowed one has arrived where the
forbidden one would have, the forbidden one is looked for. What makes that sound:
one session's messages reach the router in the order sent and are handled in that
order (a declaration before any later sample); the router forwards a sample to every
matching session at once; one link delivers samples in order, and a session hands them
on in that order to one subscriber (two subscribers' callbacks run on threads of their
own: a forbidden subscription is read from a channel, filled in arrival order). Where
the actor can send nothing allowed to the observer, a chain does it (the actor's own
allowed message seen elsewhere, then an allowed message to the observer from another
session); queries and liveliness gets read the router's state after such a sync.

The same forbidden probes against the same file with access control switched off show
each of them arriving: a probe that could see nothing cannot pass for a rule that holds.
Forbidden puts are plain `session.put`s of sessions that never declared a publisher
on their keys: such a put is sent whatever the session knows of subscribers (a
declared publisher sends only to subscribers the router told it of), so it is the
router that drops it.
"""

from __future__ import annotations

import argparse
import asyncio
import io
import itertools
import json
from pathlib import Path
from typing import Any, Callable, Iterator

import json5
import pytest
import zenoh

from edged.records import Estimate, HealthRecord
from edged_zenoh.commands import fleet_main
from edged_zenoh.output import ZenohOutput, ZenohOutputConfig
from zenoh_tls import pki  # noqa: F401 (the fixture)
from zenoh_tls import REPO, WAIT, Pki, Seen, free_port, serve_net, start_router, tls_session, wait_matching

T0 = 1_732_350_000.0


_tags = itertools.count()


def tag(what: str) -> str:
    return f"{what}-{next(_tags)}"


class Net:
    """One router and its clients: `v1`, `v1b` (vessel-1's output and input sessions),
    `v2`, `d1` (a dashboard acting), `d2` (a dashboard watching everything) and `d3` (a
    dashboard asking the router for liveliness tokens: a session that follows liveliness
    itself may answer such a get from what it has been told so far).

    Watchers declared once: d2 on `vessel/**` (samples and liveliness), v1b on its
    forecasts, v2 on its forecasts; each is known to the router before a test runs.
    """

    NAMES = {"v1": "vessel-1", "v1b": "vessel-1", "v2": "vessel-2", "d1": "fleet-dashboard", "d2": "fleet-dashboard",
             "d3": "fleet-dashboard"}

    def __init__(self, pki: Pki, endpoint: str) -> None:
        self.endpoint = endpoint
        self.s: dict[str, zenoh.Session] = {}
        self.keep: list[Any] = []
        self.d2_data, self.d2_alive, self.v1b_env, self.v2_data = Seen(), Seen(), Seen(), Seen()
        try:
            self._setup(pki)
        except BaseException:
            self.close()
            raise

    def _setup(self, pki: Pki) -> None:
        for short, cert in self.NAMES.items():
            self.s[short] = tls_session(pki, self.endpoint, cert)
        v1, v1b, v2, d2 = self.s["v1"], self.s["v1b"], self.s["v2"], self.s["d2"]
        self.keep += [
            d2.liveliness().declare_subscriber("vessel/**", self.d2_alive, history=True),
            d2.declare_subscriber("vessel/**", self.d2_data),
        ]
        ready = v1.declare_publisher("vessel/vessel-1/est/ready")
        wait_matching(ready)  # d2's declarations (both: one link, in order) are at the router
        ready.undeclare()
        self.keep += [
            v1b.declare_subscriber("vessel/vessel-1/env/current", self.v1b_env),
            v2.declare_subscriber("vessel/vessel-2/env/current", self.v2_data),
        ]
        self.sync("v1b")
        self.sync("v2")

    def sync(self, who: str) -> None:
        """An allowed put of `who` seen by d2: whatever `who` sent before is handled."""
        marker = tag("sync")
        if who.startswith("d"):
            key = "vessel/vessel-1/env/current"
        else:
            key = f"vessel/{self.NAMES[who]}/est/sync"
        self.s[who].put(key, marker)
        self.d2_data.wait(key=key, payload=marker)

    def reach(self, vessel: str) -> None:
        """A forecast from d1 seen by the vessel's forecast watcher (v1b or v2)."""
        key, marker = f"vessel/{vessel}/env/current", tag("forecast")
        self.s["d1"].put(key, marker)
        (self.v1b_env if vessel == "vessel-1" else self.v2_data).wait(key, marker)  # its only key

    def close(self) -> None:
        for d in self.keep:
            d.undeclare()
        for s in self.s.values():
            s.close()


@pytest.fixture(scope="module")
def acl_net(pki: Pki, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Net]:
    """The shipped access control (no vessel added)."""
    yield from serve_net(pki, tmp_path_factory.mktemp("acl"), Net, acl=True, extra_vessels=())


@pytest.fixture(scope="module")
def open_net(pki: Pki, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Net]:
    """The shipped file with access control switched off: the probes' own check."""
    yield from serve_net(pki, tmp_path_factory.mktemp("open"), Net, acl=False, extra_vessels=())


def _replies(session: zenoh.Session, selector: str) -> list[tuple[str, str]]:
    """Every reply to a get; it returns once every queryable the router reached is done."""
    return [(str(r.ok.key_expr), r.ok.payload.to_string()) for r in session.get(selector, timeout=WAIT)
            if r.ok is not None]


def _tokens(net: Net, selector: str = "vessel/**") -> set[str]:
    """The liveliness tokens the router holds (asked by d3, which holds and follows none)."""
    return {str(r.ok.key_expr) for r in net.s["d3"].liveliness().get(selector, timeout=WAIT) if r.ok is not None}


# -- what is allowed works ------------------------------------------------------------------
def test_vessel_publishes_its_data_to_dashboards(acl_net: Net) -> None:
    """Through declared publishers, as edged's output: they send only to subscribers the
    router told them of."""
    for key in ("vessel/vessel-1/est/stw", "vessel/vessel-1/health", "vessel/vessel-1/meas/heading/gyro"):
        pub = acl_net.s["v1"].declare_publisher(key)
        try:
            wait_matching(pub)
            marker = tag("data")
            pub.put(marker)
            acl_net.d2_data.wait(key=key, payload=marker)
        finally:
            pub.undeclare()


def test_dashboard_publishes_a_forecast_to_its_vessel(acl_net: Net) -> None:
    pub = acl_net.s["d1"].declare_publisher("vessel/vessel-1/env/current")
    try:
        wait_matching(pub)  # vessel-1's forecast subscription (the input's key)
        marker = tag("forecast")
        pub.put(marker)
        acl_net.v1b_env.wait(key="vessel/vessel-1/env/current", payload=marker)
    finally:
        pub.undeclare()


def test_dashboard_queries_a_vessel(acl_net: Net) -> None:
    """A get on the vessel's prefix, and `edged fleet`'s gets across the fleet."""
    marker = tag("latest")
    est, health = "vessel/vessel-1/est/stw", "vessel/vessel-1/health"

    def answer(q: zenoh.Query) -> None:
        for key in (est, health):
            if zenoh.KeyExpr(key).intersects(q.key_expr):
                q.reply(key, marker)

    qable = acl_net.s["v1"].declare_queryable("vessel/vessel-1/**", answer)
    try:
        acl_net.sync("v1")  # the queryable is at the router
        d2 = acl_net.s["d2"]
        assert {(est, marker), (health, marker)} <= set(_replies(d2, "vessel/vessel-1/**"))
        assert (health, marker) in _replies(d2, "vessel/*/health")
        assert (est, marker) in _replies(d2, "vessel/*/est/**")
    finally:
        qable.undeclare()


def test_vessel_liveliness_is_seen_by_dashboards(acl_net: Net) -> None:
    key = "vessel/vessel-1/alive"
    token = acl_net.s["v1"].liveliness().declare_token(key)
    try:
        acl_net.d2_alive.wait(key=key, kind="put")
        assert key in _tokens(acl_net, "vessel/*/alive")
    finally:
        token.undeclare()
    acl_net.d2_alive.wait(key=key, kind="delete")


HEALTHY = {"t": T0, "inputs": {"gnss1": {"state": "connected", "ok": True}},
           "outputs": {"zenoh": {"state": "running", "ok": True}}}


def test_edged_output_and_fleet_work_through_the_acl(acl_net: Net, pki: Pki, make_ctx: Any, tmp_path: Path) -> None:
    """edged's own output as vessel-2 and `edged fleet` as a dashboard, both over TLS."""
    c = make_ctx("zenoh", "vessel-2")
    out = ZenohOutput(ZenohOutputConfig.model_validate({
        "type": "zenoh", "mode": "client", "listen": [], "connect": [acl_net.endpoint],
        "tls": pki.client_tls("vessel-2"),
    }), c.ctx)
    fleet_cfg = tmp_path / "fleet.json5"
    fleet_cfg.write_text(json.dumps({
        "mode": "client", "connect": {"endpoints": [acl_net.endpoint]},
        "transport": {"link": {"tls": pki.client_tls("fleet-dashboard")}},
    }))

    async def scenario() -> tuple[int, str]:
        await out.open()
        try:
            await asyncio.wait_for(out.connected.wait(), WAIT)
            out.write([Estimate("stw", "stw", T0, {"stw": 5.5}), HealthRecord(T0, HEALTHY)])
            # The token is declared after the queryable: once it is seen, both are at the router.
            await asyncio.to_thread(acl_net.d2_alive.wait, key="vessel/vessel-2/alive", kind="put")
            buf = io.StringIO()
            args = argparse.Namespace(zenoh_config=str(fleet_cfg), out=buf, refreshes=1, interval=None, duration=None)
            rc = await asyncio.to_thread(fleet_main, args)
            return rc, buf.getvalue()
        finally:
            await out.close()

    rc, text = asyncio.run(scenario())
    assert rc == 0, text
    (row,) = [ln for ln in text.splitlines() if ln.startswith("vessel-2 ")]
    assert row.split()[3] == "5.50" and row.split()[-1] == "ok", text


@pytest.mark.parametrize(("cert", "connects"), [("site", True), ("another CA", False), ("none", False)])
def test_only_a_site_certificate_connects(acl_net: Net, pki: Pki, cert: str, connects: bool) -> None:
    tls: dict[str, Any] = {"root_ca_certificate": pki.ca}
    if cert != "none":  # both with the common name fleet-dashboard
        tls = pki.client_tls("fleet-dashboard", other=cert == "another CA")
    cfg = zenoh.Config()
    cfg.insert_json5("mode", '"client"')
    cfg.insert_json5("connect/endpoints", json.dumps([acl_net.endpoint]))
    cfg.insert_json5("scouting/multicast/enabled", "false")
    cfg.insert_json5("transport/link/tls", json.dumps(tls))
    if connects:
        zenoh.open(cfg).close()
    else:
        with pytest.raises(zenoh.ZError, match="Unable to connect"):
            zenoh.open(cfg).close()


# -- what is forbidden never arrives --------------------------------------------------------
# Each case tries a forbidden thing and names what of it arrived anywhere it could be seen.
Case = Callable[[Net], "tuple[list[str], list[str]]"]


def dashboard_puts_vessel_data(net: Net) -> tuple[list[str], list[str]]:
    keys = ["vessel/vessel-1/est/stw", "vessel/vessel-1/health", "vessel/vessel-1/meas/heading/gyro",
            "vessel/vessel-1/alive"]
    forged = tag("forged")
    for key in keys:
        net.s["d1"].put(key, forged)
    net.sync("d1")
    return keys, [k for k in keys if net.d2_data.has(key=k, payload=forged, kind=None)]


def dashboard_deletes_vessel_data(net: Net) -> tuple[list[str], list[str]]:
    keys = [f"vessel/vessel-1/est/{tag('gone')}", f"vessel/vessel-1/meas/heading/{tag('gone')}"]
    for key in keys:
        net.s["d1"].delete(key)
    net.sync("d1")
    return keys, [k for k in keys if net.d2_data.has(key=k, kind="delete")]


def dashboard_holds_a_liveliness_token(net: Net) -> tuple[list[str], list[str]]:
    keys = [f"vessel/{tag('ghost')}/alive", f"vessel/vessel-1/{tag('token')}"]
    tokens = [net.s["d1"].liveliness().declare_token(k) for k in keys]
    try:
        net.sync("d1")
        alive = _tokens(net)
    finally:
        for t in tokens:
            t.undeclare()
    return keys, [k for k in keys if k in alive or net.d2_alive.has(key=k, kind=None)]


def dashboard_answers_queries(net: Net) -> tuple[list[str], list[str]]:
    forged, hits = tag("forged"), []

    def answer(q: zenoh.Query) -> None:
        hits.append(str(q.key_expr))
        q.reply("vessel/vessel-1/est/stw", forged)

    qable = net.s["d1"].declare_queryable("vessel/vessel-1/**", answer)
    try:
        net.sync("d1")  # the queryable's declaration is handled
        replies = _replies(net.s["d2"], "vessel/vessel-1/**")
    finally:
        qable.undeclare()
    return ["queried", "replied"], (["queried"] if hits else []) + (["replied"] if (
        "vessel/vessel-1/est/stw", forged) in replies else [])


def vessel_puts_another_vessels_data(net: Net) -> tuple[list[str], list[str]]:
    keys = ["vessel/vessel-2/est/stw", "vessel/vessel-2/health", "vessel/vessel-2/meas/heading/gyro"]
    forged = tag("forged")
    for key in keys:
        net.s["v1"].put(key, forged)
    net.sync("v1")
    return keys, [k for k in keys if net.d2_data.has(key=k, payload=forged, kind=None)]


def vessel_puts_its_own_forecast(net: Net) -> tuple[list[str], list[str]]:
    """Forecasts come from shore, wildcards included."""
    keys = ["vessel/vessel-1/env/current", "vessel/vessel-1/*/current", "vessel/vessel-1/**", "vessel/*/env/current"]
    forged = tag("forged")
    for key in keys:
        net.s["v1"].put(key, forged)
    net.sync("v1")  # d2 would have them now, and the router would have passed them on
    net.reach("vessel-1")
    net.reach("vessel-2")
    watchers = (net.d2_data, net.v1b_env, net.v2_data)
    return keys, [k for k in keys if any(w.has(key=k, payload=forged, kind=None) for w in watchers)]


def _payloads(sub: Any) -> list[str]:
    """What a FifoChannel subscriber holds now. A channel is filled on zenoh's receiving
    thread in the order samples came; callbacks run on a thread each, so only within one
    callback is that order kept."""
    out = []
    while (sample := sub.try_recv()) is not None:
        out.append(sample.payload.to_string())
    return out


def vessel_reads_another_vessels_data(net: Net) -> tuple[list[str], list[str]]:
    keys = ["vessel/**", "vessel/vessel-1/**", "vessel/vessel-1/est/stw"]
    marker = tag("vessel-1-data")
    subs = {k: net.s["v2"].declare_subscriber(k, zenoh.handlers.FifoChannel(1024)) for k in keys}
    try:
        net.sync("v2")  # its subscriptions are handled
        net.s["v1"].put("vessel/vessel-1/est/stw", marker)
        net.d2_data.wait(key="vessel/vessel-1/est/stw", payload=marker)  # passed on to all it may reach
        net.reach("vessel-2")  # later on the same link to vessel-2
        return keys, [k for k, sub in subs.items() if marker in _payloads(sub)]
    finally:
        for sub in subs.values():
            sub.undeclare()


def vessel_receives_another_vessels_forecast(net: Net) -> tuple[list[str], list[str]]:
    key = "vessel/vessel-1/env/current"
    sub = net.s["v2"].declare_subscriber(key, zenoh.handlers.FifoChannel(1024))
    try:
        net.sync("v2")
        forecast = tag("not-for-vessel-2")
        net.s["d1"].put(key, forecast)
        net.reach("vessel-2")  # after it, from the same dashboard to the same vessel
        return [key], [key] if forecast in _payloads(sub) else []
    finally:
        sub.undeclare()


def vessel_holds_a_foreign_liveliness_token(net: Net) -> tuple[list[str], list[str]]:
    keys = [f"vessel/{tag('ghost')}/alive", f"vessel/vessel-1/{tag('token')}"]
    tokens = [net.s["v1"].liveliness().declare_token(k) for k in keys]
    try:
        net.sync("v1")
        alive = _tokens(net)
    finally:
        for t in tokens:
            t.undeclare()
    return keys, [k for k in keys if k in alive or net.d2_alive.has(key=k, kind=None)]


def vessel_answers_for_another_vessel(net: Net) -> tuple[list[str], list[str]]:
    forged, hits = tag("forged"), []

    def answer(q: zenoh.Query) -> None:
        hits.append(str(q.key_expr))
        q.reply("vessel/vessel-2/est/stw", forged)

    qable = net.s["v1"].declare_queryable("vessel/vessel-2/**", answer)
    try:
        net.sync("v1")
        replies = _replies(net.s["d2"], "vessel/vessel-2/**")
    finally:
        qable.undeclare()
    return ["queried", "replied"], (["queried"] if hits else []) + (["replied"] if (
        "vessel/vessel-2/est/stw", forged) in replies else [])


def vessel_replies_outside_its_data(net: Net) -> tuple[list[str], list[str]]:
    """Its queryable is allowed; replies with a forecast or another vessel's key are not."""
    forged = tag("forged")
    keys = ["vessel/vessel-1/env/current", "vessel/vessel-2/est/stw"]
    legit = f"vessel/vessel-1/est/{tag('legit')}"

    def answer(q: zenoh.Query) -> None:
        for key in (*keys, legit):
            q.reply(key, forged)

    qable = net.s["v1"].declare_queryable("vessel/vessel-1/**", answer)
    try:
        net.sync("v1")
        replies = _replies(net.s["d2"], "vessel/**")
    finally:
        qable.undeclare()
    assert (legit, forged) in replies  # the same answer's allowed reply arrived
    return keys, [k for k in keys if (k, forged) in replies]


FORBIDDEN: dict[str, Case] = {
    "dashboard-puts-vessel-data": dashboard_puts_vessel_data,
    "dashboard-deletes-vessel-data": dashboard_deletes_vessel_data,
    "dashboard-holds-a-liveliness-token": dashboard_holds_a_liveliness_token,
    "dashboard-answers-queries": dashboard_answers_queries,
    "vessel-puts-another-vessels-data": vessel_puts_another_vessels_data,
    "vessel-puts-its-own-forecast": vessel_puts_its_own_forecast,
    "vessel-reads-another-vessels-data": vessel_reads_another_vessels_data,
    "vessel-receives-another-vessels-forecast": vessel_receives_another_vessels_forecast,
    "vessel-holds-a-foreign-liveliness-token": vessel_holds_a_foreign_liveliness_token,
    "vessel-answers-for-another-vessel": vessel_answers_for_another_vessel,
    "vessel-replies-outside-its-data": vessel_replies_outside_its_data,
}


@pytest.mark.parametrize("access_control", ["on", "off"])
@pytest.mark.parametrize("case", list(FORBIDDEN))
def test_forbidden_never_arrives(case: str, access_control: str, request: pytest.FixtureRequest) -> None:
    """With access control on nothing of it arrives; off, all of it (the probe works)."""
    net = request.getfixturevalue("acl_net" if access_control == "on" else "open_net")
    attempted, arrived = FORBIDDEN[case](net)
    if access_control == "on":
        assert arrived == [], f"{case}: arrived through the access control: {arrived}"
    else:
        assert arrived == attempted, f"{case}: the probe cannot see {sorted(set(attempted) - set(arrived))}"


# -- on board: the local router with logins (deploy/zenoh/router-local-acl.json5) ---------
LOCAL_ROUTER = REPO / "deploy" / "zenoh" / "router-local-acl.json5"
LOCAL_DAEMON = REPO / "deploy" / "zenoh" / "edged-local-auth.json5"
USERS = ("edged", "forecasts", "bridge")


class Local:
    """The shipped local router (its users file and listen endpoint replaced), and the
    shipped daemon file with its password and the router's endpoint."""

    def __init__(self, folder: Path) -> None:
        import secrets

        self.passwords = {u: secrets.token_hex(16) for u in USERS}
        users = folder / "local-users.txt"
        users.write_text("".join(f"{u}:{p}\n" for u, p in self.passwords.items()))
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        cfg = json5.loads(LOCAL_ROUTER.read_text())
        cfg["transport"]["auth"]["usrpwd"]["dictionary_file"] = str(users)
        cfg["listen"]["endpoints"] = [self.endpoint]
        (folder / "router.json5").write_text(json.dumps(cfg))
        daemon = json5.loads(LOCAL_DAEMON.read_text())
        daemon["transport"]["auth"]["usrpwd"]["password"] = self.passwords["edged"]
        daemon["connect"]["endpoints"] = [self.endpoint]
        self.daemon_file = folder / "edged-local-auth.json5"
        self.daemon_file.write_text(json.dumps(daemon))
        self.router = start_router(folder / "router.json5")

    def session(self, user: str | None, password: str | None = None) -> zenoh.Session:
        cfg = zenoh.Config()
        cfg.insert_json5("mode", '"client"')
        cfg.insert_json5("connect/endpoints", json.dumps([self.endpoint]))
        cfg.insert_json5("scouting/multicast/enabled", "false")
        cfg.insert_json5("scouting/gossip/enabled", "false")
        if user is not None:
            pw = self.passwords.get(user, "x") if password is None else password
            cfg.insert_json5("transport/auth/usrpwd", json.dumps({"user": user, "password": pw}))
        return zenoh.open(cfg)


@pytest.fixture(scope="module")
def local(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Local]:
    lo = Local(tmp_path_factory.mktemp("local"))
    try:
        yield lo
    finally:
        lo.router.stop()


@pytest.mark.parametrize(("user", "password", "connects"), [
    ("bridge", None, True), (None, None, False), ("bridge", "wrong", False), ("mallory", "x", False),
])
def test_local_router_refuses_a_session_without_a_valid_login(local: Local, user: str | None,
                                                             password: str | None, connects: bool) -> None:
    if connects:
        local.session(user, password).close()
    else:
        with pytest.raises(zenoh.ZError, match="Unable to connect"):
            local.session(user, password).close()


def test_local_daemon_takes_forecasts_from_the_forecasts_user_only(local: Local, make_ctx: Any) -> None:
    """edged's output and input with `--zenoh-config edged-local-auth.json5` (as `edged run`
    passes it) work through the local router; a logged-in reader cannot feed forecasts."""
    from edged.records import Measurement, RawRecord
    from edged_zenoh.input import ZenohInput, ZenohInputConfig

    options = {"zenoh_config": str(local.daemon_file)}
    co, ci = make_ctx("zenoh", "vessel-1", options), make_ctx("shore", "vessel-1", options)
    out = ZenohOutput(ZenohOutputConfig.model_validate({"type": "zenoh"}), co.ctx)
    inp = ZenohInput(ZenohInputConfig.model_validate({"type": "zenoh"}), ci.ctx)
    forecasts, bridge = local.session("forecasts"), local.session("bridge")
    env, alive = "vessel/vessel-1/env/current", Seen()
    watch = bridge.liveliness().declare_subscriber("vessel/*/alive", alive, history=True)

    async def scenario() -> None:
        received: asyncio.Queue = asyncio.Queue()
        ci.ctx.publish = received.put_nowait

        async def forecast_arrives(drift: float) -> None:
            while True:
                r = await asyncio.wait_for(received.get(), WAIT)
                if isinstance(r, RawRecord):
                    assert json.loads(r.data)["drift"] == drift, f"a forecast nobody allowed: {r.data!r}"
                if isinstance(r, Measurement) and r.kind == "current":
                    assert r.values["drift"] == drift
                    return

        await out.open()
        task = asyncio.create_task(inp.run())
        try:
            await asyncio.wait_for(out.connected.wait(), WAIT)
            await asyncio.wait_for(inp.subscribed.wait(), WAIT)
            out.write([Estimate("stw", "stw", T0, {"stw": 5.5})])
            pub = forecasts.declare_publisher(env)
            await asyncio.to_thread(wait_matching, pub)  # the input's subscription, the only one
            pub.put(json.dumps({"t": T0, "set": 0.7, "drift": 0.5}))
            await forecast_arrives(0.5)

            # A logged-in reader's forecast, then its query: answered by the daemon's output
            # once the router handled both, in that order (the forecast first).
            await asyncio.to_thread(alive.wait, key="vessel/vessel-1/alive", kind="put")  # queryable declared
            bridge.put(env, json.dumps({"t": T0, "set": 0.7, "drift": 9.0}))
            replies = await asyncio.to_thread(_replies, bridge, "vessel/vessel-1/**")
            assert [k for k, _ in replies] == ["vessel/vessel-1/est/stw"]
            pub.put(json.dumps({"t": T0 + 60, "set": 0.7, "drift": 0.4}))  # after it on the input's link
            await forecast_arrives(0.4)  # and nothing in between
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
            await out.close()

    try:
        asyncio.run(scenario())
    finally:
        watch.undeclare()
        forecasts.close()
        bridge.close()
