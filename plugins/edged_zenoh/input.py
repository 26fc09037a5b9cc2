"""The Zenoh input: sea-current forecasts from ashore and any mapped key -> measurements.

Zenoh delivers samples on its own threads, which must never wait for the event loop.
Each subscription therefore gets a bounded `FifoChannel`; the loop blocks on `recv` in
a worker thread and then drains what else is queued with `try_recv`, the bridge that
measured fastest (DEPENDENCIES). The blocked `recv` calls get a small executor of their
own so that they never occupy the shared default pool other plugins rely on; closing
the session ends them.
"""

from __future__ import annotations

import asyncio
from concurrent.futures import ThreadPoolExecutor
from typing import Any, ClassVar

import zenoh
from pydantic import BaseModel, ConfigDict, Field, field_validator

from edged.health import ComponentHealth
from edged.plugin import NO_MARKS, Decoder, InputConfig, InputPlugin, OwnMarks, PluginContext
from edged.config import KindName
from edged.records import RawRecord

from .decode import ZenohDecoder
from .keys import KeySpace, valid_chunk
from .session import SessionOpener, close_session, plugin_session_config, plugin_session_link
from .zconfig import DEFAULT_LISTEN, ZenohSettings, check_key_prefix, safe_defaults, unguarded_endpoints

__all__ = ["ZenohInput", "ZenohInputConfig", "KeyMapping"]


class KeyMapping(BaseModel):
    """A zenoh key (may hold wildcards) whose JSON payloads are measurements of `kind`."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    key: str
    kind: KindName
    source: str

    @field_validator("source")
    @classmethod
    def _source(cls, v: str) -> str:
        if not valid_chunk(v):
            raise ValueError("a source name cannot be empty nor hold '/', '*', '$', '?', '#' or spaces")
        return v


class ZenohInputConfig(InputConfig, ZenohSettings):
    #: Key prefix; default `vessel/<vessel_id>`.
    key_prefix: str | None = None
    #: Subscribe to `<prefix>/env/current` (sea-current forecasts from ashore).
    current: bool = True
    subscriptions: list[KeyMapping] = Field(default_factory=list)
    #: Samples a subscription may queue before zenoh's thread would have to wait.
    channel_size: int = Field(65536, ge=16)

    @field_validator("key_prefix")
    @classmethod
    def _prefix(cls, v: str | None) -> str | None:
        return None if v is None else check_key_prefix(v)


#: By default the input reaches the zenoh network as a client of the daemon's own
#: output session (or a ship router) on the default endpoint: a second peer listening
#: on the same port would only fall back to another one and hear nothing.
INPUT_DEFAULTS = safe_defaults(mode="client", listen=(), connect=(DEFAULT_LISTEN,))


class ZenohInput(InputPlugin):
    Config: ClassVar[type[ZenohInputConfig]] = ZenohInputConfig
    description: ClassVar[str] = "sea-current forecasts and other measurements received over Eclipse Zenoh"
    protocol: ClassVar[str] = "zenoh"

    def __init__(self, config: ZenohInputConfig, ctx: PluginContext) -> None:
        super().__init__(config, ctx)
        self.keyspace = KeySpace(config.key_prefix or f"vessel/{ctx.vessel_id}")
        self._decoder: Decoder = ctx.decoder or self.make_decoder(ctx.name, config, ctx.health)
        #: Set once every subscriber is declared: tests and tools may await it.
        self.subscribed = asyncio.Event()

    @classmethod
    def make_decoder(cls, source: str, config: Any, health: ComponentHealth, own: OwnMarks = NO_MARKS) -> Decoder:
        maps = getattr(config, "subscriptions", None) or []
        return ZenohDecoder(health, {m.key: m.kind for m in maps})

    def _routes(self) -> list[tuple[str, str, str | None]]:
        """(key expression, source, kind) of every subscription; kind None = by key."""
        routes: list[tuple[str, str, str | None]] = []
        if self.config.current:
            routes.append((self.keyspace.env_current, self.ctx.name, "current"))
        routes += [(m.key, m.source, m.kind) for m in self.config.subscriptions]
        return routes

    def _base_config(self) -> dict[str, Any]:
        # The input's own default (client of the local endpoint) unless the user set
        # the mode: then the ordinary peer defaults apply.
        return safe_defaults() if "mode" in self.config.model_fields_set else INPUT_DEFAULTS

    def check(self) -> None:
        """The zenoh configuration files named here or by --zenoh-config must load.

        A warning (not an error) for each endpoint through which other hosts can publish
        what this input takes in (the sea-current forecasts the STW estimator uses, any
        mapped key) with no access control: on this computer's loopback the local
        processes are trusted (deploy/zenoh/README.md), beyond it nobody is.
        """
        cfg = plugin_session_config(self.config, self.ctx, self._base_config())  # ZenohConfigError is a ValueError
        keys = [key for key, _, _ in self._routes()]
        for endpoint in unguarded_endpoints(cfg) if keys else ():
            self.ctx.log.warning(
                "event=zenoh-input-unguarded input=%s keys=%s endpoint=%s reason=%r",
                self.ctx.name, ",".join(keys), endpoint,
                "any host that reaches this endpoint can publish these keys: no access control "
                "(access_control with default deny, transport/auth/usrpwd logins, mutual TLS; see deploy/zenoh/README.md)",
            )

    async def run(self) -> None:
        """Open the session with the shared link (`edged.link`): the input's state is
        `connecting` / `disconnected` until zenoh opens, then `connected`."""
        cfg = plugin_session_config(self.config, self.ctx, self._base_config())
        opener = SessionOpener(cfg, self.ctx.health, self.ctx.log, listen_fallback=self.config.listen_fallback)
        link = plugin_session_link(self.config, self.ctx)
        await link.run(opener, self._serve)  # _serve closes the session itself

    async def _serve(self, session: zenoh.Session) -> None:
        """Subscribe and read until the session closes (or the task is cancelled)."""
        routes = self._routes()
        pool = ThreadPoolExecutor(max_workers=max(1, len(routes)), thread_name_prefix=f"{self.ctx.name}-recv")
        try:
            subs = [
                (session.declare_subscriber(key, zenoh.handlers.FifoChannel(self.config.channel_size)), source, kind)
                for key, source, kind in routes
            ]
            self.subscribed.set()
            async with asyncio.TaskGroup() as tg:
                for sub, source, kind in subs:
                    tg.create_task(self._read(sub, source, kind, pool))
        finally:
            self.subscribed.clear()
            await close_session(session)  # ends every recv blocked in the pool
            pool.shutdown(wait=False)

    async def _read(self, sub: Any, source: str, kind: str | None, pool: ThreadPoolExecutor) -> None:
        loop = asyncio.get_running_loop()
        while True:
            try:
                sample = await loop.run_in_executor(pool, sub.recv)
            except zenoh.ZError:  # channel closed: the session is going away
                return
            self._ingest(sample, source, kind)
            while (sample := sub.try_recv()) is not None:
                self._ingest(sample, source, kind)

    def _ingest(self, sample: zenoh.Sample, source: str, kind: str | None) -> None:
        health = self.ctx.health
        if sample.kind != zenoh.SampleKind.PUT:
            health.count("ignored.delete")
            return
        health.count("received")
        meta = {"key": str(sample.key_expr)}
        if kind is not None:
            meta["kind"] = kind
        raw = RawRecord(self.protocol, source, self.ctx.clock.now(), sample.payload.to_bytes(), meta)
        publish = self.ctx.publish
        publish(raw)
        for m in self._decoder.decode(raw):
            publish(m)
