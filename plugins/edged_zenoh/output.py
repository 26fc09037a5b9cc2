"""The Zenoh output: estimates, measurements and health under `vessel/<id>` (DESIGN §6).

The daemon must run whether or not anyone listens: the session is opened in the
background (`session.open_session`, retried with backoff) and until it is open every
record still updates the latest-value store, so the first query after the link comes
up is answered with current values. Raw records are never published.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any, Callable, ClassVar

import zenoh
from pydantic import Field, field_validator

from edged.plugin import OutputConfig, OutputPlugin, PluginContext
from edged.records import KINDS, Estimate, HealthRecord, Measurement

from .keys import KeySpace, encode, payload_of, valid_chunk
from .latest import LatestValues
from .ratelimit import DataTimeRateLimiter
from .session import close_session, open_plugin_session, plugin_session_config
from .zconfig import ZenohSettings, check_key_prefix

__all__ = ["ZenohOutput", "ZenohOutputConfig"]

_JSON = zenoh.Encoding.APPLICATION_JSON


class ZenohOutputConfig(OutputConfig, ZenohSettings):
    #: Key prefix; default `vessel/<vessel_id>`.
    key_prefix: str | None = None
    #: Publish canonical measurements under `meas/<kind>/<source>` at all.
    measurements: bool = True
    #: Highest rate (Hz of data time) per measurement topic; 0 switches a kind off.
    meas_default_hz: float = Field(10.0, ge=0)
    meas_max_hz: dict[str, float] = Field(default_factory=dict)
    #: Answer `get` on `<prefix>/**` with the latest value of each key.
    queryable: bool = True

    @field_validator("key_prefix")
    @classmethod
    def _prefix(cls, v: str | None) -> str | None:
        return None if v is None else check_key_prefix(v)

    @field_validator("meas_max_hz")
    @classmethod
    def _kinds(cls, v: dict[str, float]) -> dict[str, float]:
        for kind, hz in v.items():
            if kind not in KINDS:
                raise ValueError(f"unknown measurement kind {kind!r} (known: {', '.join(KINDS)})")
            if hz < 0:
                raise ValueError(f"{kind}: a rate cannot be negative")
        return v


_NO_KEY = ""


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
            {k: config.meas_max_hz.get(k, config.meas_default_hz) for k in KINDS} if config.measurements else {}
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
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._queryable: zenoh.Queryable | None = None
        self._token: zenoh.LivelinessToken | None = None
        self._connector: asyncio.Task[None] | None = None
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
        self.ctx.health.info["key_prefix"] = self.keyspace.prefix
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

    async def close(self) -> None:
        task, self._connector = self._connector, None
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
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
        return {"queries": self._queries, "query_errors": self._query_errors, "keys": len(self.latest)}

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
        sent = limited = unsent = 0
        session = self._session
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
                pub = self._publishers[key] = session.declare_publisher(key, encoding=_JSON)
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
