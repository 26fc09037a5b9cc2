"""The Zenoh output: estimates, measurements and health under `vessel/<id>` (DESIGN §6).

The daemon must run whether or not anyone listens: the session is opened in the
background (`session.open_session`, retried with backoff) and until it is open every
record still updates the latest-value store, so the first query after the link comes
up is answered with current values. Raw records are never published.

Where the samples go is part of health (`info["zenoh"]`, `info["routers"]`,
`info["peers"]`): a client whose router is gone (an outage of the shore link) has an
open session that sends nothing, so in client mode the records written meanwhile are
counted `unsent.no_route` instead of `published`, `info["zenoh"]` says
`disconnected` and the output's state is `disconnected` (`ok: false`): the daemon goes
on, but this output's link is down, and a dashboard must see it. The router count is
looked at in every health `status()` and, in `write`, at most every
`ROUTE_CHECK_INTERVAL` seconds of the clock's monotonic time. A peer publishes to
whoever is connected at the time: nobody listening is normal there, not a loss.

`ready()` waits (bounded) for the link, so that a replay's first samples are not
published before anyone can receive them (`replay_wait`).
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any, Callable, ClassVar, Literal

import zenoh
from pydantic import Field, field_validator

from edged.link import stop_task
from edged.plugin import OutputConfig, OutputPlugin, PluginContext
from edged.records import KINDS, Estimate, HealthRecord, Measurement

from .keys import KeySpace, encode, payload_of, valid_chunk
from .latest import LatestValues
from edged.ratelimit import DataTimeRateLimiter, MeasurementRates
from .session import close_session, open_plugin_session, plugin_session_config
from .zconfig import ZenohSettings, check_key_prefix

__all__ = ["ZenohOutput", "ZenohOutputConfig"]

_JSON = zenoh.Encoding.APPLICATION_JSON


class ZenohOutputConfig(OutputConfig, MeasurementRates, ZenohSettings):
    #: Key prefix; default `vessel/<vessel_id>`.
    key_prefix: str | None = None
    #: Publish canonical measurements under `meas/<kind>/<source>` at all.
    measurements: bool = True
    #: Answer `get` on `<prefix>/**` with the latest value of each key.
    queryable: bool = True
    #: `edged replay`: seconds to wait at the start for the session to be linked (a
    #: router in client mode, a peer when `connect` names one) before the first record
    #: is published (`ZenohOutput.ready`); 0 does not wait.
    replay_wait: float = Field(5.0, ge=0, le=3600)
    #: What zenoh does with a sample when a link's send queue is full: `drop` it (the
    #: event loop never waits for a slow link), `block` until there is room (every
    #: sample is delivered; `put` may wait), `auto`: `block` when the runtime says it
    #: is a replay (`ctx.options["replay"]`), else `drop`. A replay at full speed
    #: publishes faster than any link carries: with `drop` its tail is lost.
    congestion_control: Literal["auto", "drop", "block"] = "auto"

    @field_validator("key_prefix")
    @classmethod
    def _prefix(cls, v: str | None) -> str | None:
        return None if v is None else check_key_prefix(v)



_NO_KEY = ""

#: Seconds (of `ctx.clock.monotonic()`) a router count is trusted by `write`.
ROUTE_CHECK_INTERVAL = 0.5
#: Seconds between looks at the link while `ready()` waits.
READY_POLL = 0.02
#: States set by the runtime and the supervisor, which the link state never overrides.
_RUNTIME_STATES = frozenset({"backoff", "failed", "finished", "stopped", "closed"})


def _connect_endpoints(cfg: dict[str, Any]) -> list[str]:
    eps = (cfg.get("connect") or {}).get("endpoints") or []
    if isinstance(eps, dict):
        eps = eps.get(cfg.get("mode", "peer")) or []
    return list(eps)


class ZenohOutput(OutputPlugin):
    Config: ClassVar[type[ZenohOutputConfig]] = ZenohOutputConfig
    description: ClassVar[str] = "publish estimates, measurements and health over Eclipse Zenoh"
    #: Raw records are recorded, not published: the router need not queue them here.
    exclude_keys: ClassVar[frozenset[str]] = frozenset({"raw"})

    def __init__(self, config: ZenohOutputConfig, ctx: PluginContext) -> None:
        super().__init__(config, ctx)
        self.keyspace = KeySpace(config.key_prefix or f"vessel/{ctx.vessel_id}")
        self.latest = LatestValues()
        #: Set while a session is open: tests and the runtime may await it.
        self.connected = asyncio.Event()
        self._limiter = DataTimeRateLimiter()
        self._hz: dict[str, float] = (
            {k: config.hz(k) for k in KINDS} if config.measurements else {}
        )
        # Key per (kind, source) / estimate name; _NO_KEY when the name cannot be a key.
        self._meas_keys: dict[tuple[str, str], str] = {}
        self._est_keys: dict[str, str] = {}
        self._routes: dict[type, Callable[[Any], tuple[str, bool]]] = {
            Measurement: self._route_measurement,
            Estimate: self._route_estimate,
            HealthRecord: self._route_health,
        }
        self._session: zenoh.Session | None = None
        cc = config.congestion_control
        if cc == "auto":
            cc = "block" if ctx.options.get("replay") else "drop"
        self._congestion = zenoh.CongestionControl.BLOCK if cc == "block" else zenoh.CongestionControl.DROP
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._queryable: zenoh.Queryable | None = None
        self._token: zenoh.LivelinessToken | None = None
        self._connector: asyncio.Task[None] | None = None
        self._mode = "peer"
        self._connects: list[str] = []
        # Client mode: is a router connected (None: not looked at yet), and when looked.
        self._routed: bool | None = None
        self._route_t = float("-inf")
        # Touched from zenoh's query thread: plain ints reported through status().
        self._queries = 0
        self._query_errors = 0

    def check(self) -> None:
        """The zenoh configuration files named here or by --zenoh-config must load."""
        plugin_session_config(self.config, self.ctx)  # ZenohConfigError is a ValueError

    # -- lifecycle ---------------------------------------------------------------
    async def open(self) -> None:
        """Check the configuration now; connect in the background, never failing."""
        cfg = plugin_session_config(self.config, self.ctx)
        self._mode = str(cfg.get("mode") or "peer")
        self._connects = _connect_endpoints(cfg)
        self.ctx.health.info["key_prefix"] = self.keyspace.prefix
        self.ctx.health.info["congestion_control"] = (
            "block" if self._congestion == zenoh.CongestionControl.BLOCK else "drop"
        )
        self.ctx.health.info["zenoh"] = "connecting"
        self._connector = asyncio.create_task(self._connect(cfg), name=f"{self.ctx.name}.connect")

    async def _connect(self, cfg: dict[str, Any]) -> None:
        session = await open_plugin_session(self.config, self.ctx, cfg)
        try:
            if self.config.queryable:
                self._queryable = session.declare_queryable(self.keyspace.everything, self._on_query)
            self._token = session.liveliness().declare_token(self.keyspace.alive)
        except BaseException:
            await close_session(session)
            raise
        self._session = session
        self.connected.set()
        self._routed = None
        self._check_route(session)

    # -- the link --------------------------------------------------------------------
    @property
    def client(self) -> bool:
        return self._mode == "client"

    def _check_route(self, session: zenoh.Session) -> bool:
        """Client mode: look whether a router is connected now; update the link state
        in health when it changed. Other modes: always True."""
        if not self.client:
            return True
        try:
            routed = bool(session.info.routers_zid())
        except zenoh.ZError:
            routed = False
        return self._note_route(routed)

    def _note_route(self, routed: bool) -> bool:
        self._route_t = self.ctx.clock.monotonic()
        if routed != self._routed:
            self._routed = routed
            self._show_link(routed)
        return routed

    def _show_link(self, up: bool) -> None:
        h = self.ctx.health
        h.info["zenoh"] = "connected" if up else "disconnected"
        if up:
            if h.state == "disconnected":
                h.set_state("running", "zenoh router connected")
        elif h.state not in _RUNTIME_STATES:
            h.set_state("disconnected", "no zenoh router connected")
            h.error("zenoh: no router connected: samples are not sent (unsent.no_route)")

    def _route_ok(self, session: zenoh.Session) -> bool:
        """`_check_route` at most every ROUTE_CHECK_INTERVAL s (write's hot path)."""
        if not self.client:
            return True
        if self._routed is None or self.ctx.clock.monotonic() - self._route_t >= ROUTE_CHECK_INTERVAL:
            return self._check_route(session)
        return self._routed

    def _linked(self, session: zenoh.Session) -> bool:
        """Someone can receive what is published: a router (client), a peer or router
        when `connect` names endpoints (peer); a listening peer or a router is linked
        once open (who connects to it is not known in advance)."""
        if self.client:
            return self._check_route(session)
        if self._mode == "peer" and self._connects:
            try:
                return bool(session.info.peers_zid()) or bool(session.info.routers_zid())
            except zenoh.ZError:
                return False
        return True

    async def ready(self, timeout: float | None = None) -> bool:
        """Wait until the session is open and linked (see `_linked`), at most `timeout`
        seconds of wall time (default: `replay_wait`); True when linked.

        For `edged replay`: awaited before the first record is fed, so that a
        subscriber gets the whole voyage. May be called before `open()` has run (the
        wait includes the session's opening); never raises on a missing link.
        """
        if timeout is None:
            timeout = self.config.replay_wait
        loop = asyncio.get_running_loop()
        deadline = loop.time() + max(0.0, timeout)
        while True:
            session = self._session
            if session is not None and not session.is_closed() and self._linked(session):
                return True
            left = deadline - loop.time()
            if left <= 0:
                return False
            if session is None:
                try:
                    async with asyncio.timeout(left):
                        await self.connected.wait()
                except TimeoutError:
                    return False
            else:
                await asyncio.sleep(min(READY_POLL, left))

    async def close(self) -> None:
        task, self._connector = self._connector, None
        await stop_task(task)
        session, self._session = self._session, None
        self.connected.clear()
        token, self._token = self._token, None
        if token is not None:
            with contextlib.suppress(zenoh.ZError):
                token.undeclare()
        self._publishers.clear()
        self._queryable = None
        await close_session(session)
        self.ctx.health.info["zenoh"] = "closed"

    def status(self) -> dict[str, Any]:
        out: dict[str, Any] = {"queries": self._queries, "query_errors": self._query_errors, "keys": len(self.latest)}
        session = self._session
        if session is None:
            if self.client:
                h = self.ctx.health
                if h.state not in _RUNTIME_STATES and h.state != "disconnected":
                    h.set_state("disconnected", "zenoh session not open")
            return out
        try:
            routers = len(session.info.routers_zid())
            out["peers"] = len(session.info.peers_zid())
        except zenoh.ZError:
            routers = 0
        out["routers"] = routers
        if self.client:
            self._note_route(routers > 0)  # the count shown is the one judged
        return out

    # -- records -----------------------------------------------------------------
    def _key(self, make: Callable[..., str], *chunks: str) -> str:
        if all(valid_chunk(c) for c in chunks):
            return make(*chunks)
        self.ctx.health.count("rejected.bad_key")
        self.ctx.health.error(f"cannot publish {'/'.join(chunks)!r}: not a valid zenoh key chunk")
        return _NO_KEY

    def _route_measurement(self, m: Measurement) -> tuple[str, bool]:
        hz = self._hz.get(m.kind, 0.0)
        if hz <= 0.0:
            return _NO_KEY, False
        ck = (m.kind, m.source)
        key = self._meas_keys.get(ck)
        if key is None:
            key = self._meas_keys[ck] = self._key(self.keyspace.meas, m.kind, m.source)
        return key, bool(key) and self._limiter.allow(key, m.t, hz)

    def _route_estimate(self, e: Estimate) -> tuple[str, bool]:
        key = self._est_keys.get(e.name)
        if key is None:
            key = self._est_keys[e.name] = self._key(self.keyspace.est, e.name)
        return key, bool(key)

    def _route_health(self, h: HealthRecord) -> tuple[str, bool]:
        return self.keyspace.health, True

    def write(self, batch: list[Any]) -> None:
        routes = self._routes
        stored: list[tuple[str, Any]] = []
        sent = limited = unsent = no_route = 0
        session = self._session
        routed = session is not None and self._route_ok(session)
        for rec in batch:
            route = routes.get(type(rec))
            if route is None:  # raw records and anything unknown: not published
                continue
            key, publish = route(rec)
            if not key:
                continue
            stored.append((key, rec))
            if not publish:
                limited += 1
            elif session is None:
                unsent += 1
            elif not routed:
                no_route += 1
            elif self._put(session, key, rec):
                sent += 1
        self.latest.update(stored)
        health = self.ctx.health
        if sent:
            health.count("published", sent)
        if limited:
            health.count("rate_limited", limited)
        if unsent:
            health.count("unsent.no_session", unsent)
        if no_route:
            health.count("unsent.no_route", no_route)

    def _put(self, session: zenoh.Session, key: str, rec: Any) -> bool:
        health = self.ctx.health
        try:
            data, sanitised = encode(payload_of(rec))
        except TypeError as exc:
            health.count("rejected.unserialisable")
            health.error(f"{key}: {exc}")
            return False
        if sanitised:
            health.count("nonfinite_as_null")
        try:
            pub = self._publishers.get(key)
            if pub is None:
                pub = self._publishers[key] = session.declare_publisher(
                    key, encoding=_JSON, congestion_control=self._congestion
                )
            pub.put(data)
        except zenoh.ZError as exc:
            health.count("put_errors")
            health.error(f"zenoh put {key}: {exc}")
            return False
        return True

    # -- queries (zenoh's thread) -------------------------------------------------
    def _on_query(self, query: zenoh.Query) -> None:
        """Reply with the latest value of every key the query's key expression covers.

        Runs on zenoh's thread: it must never raise and never wait on the event loop.
        """
        self._queries += 1
        try:
            for key, rec in self.latest.matching(query.key_expr):
                try:
                    data, _ = encode(payload_of(rec))
                except TypeError:
                    continue
                query.reply(key, data, encoding=_JSON)
        except Exception:  # a query must never take zenoh's thread down
            self._query_errors += 1
