"""The live Foxglove output: a WebSocket server with the recording's channels.

A browser (Foxglove) connected to it sees what an MCAP recording of the same records
holds: the same topics (`/est/<name>`, `/meas/<kind>/<source>`, `/location/<source>`,
`/health`), the same JSON schemas and the same JSON bytes, because both take them from
`edged.channels` (`encode`, `dumps`, `to_ns`) and `edged.schemas`; a
message's log time is the record's data time, as in the recording. So one layout
(`deploy/foxglove-layout.json`) serves the live vessel and its recordings.

The server is foxglove-sdk's (a Rust server on its own threads). Each output has a
context of its own, so two instances never share channels. A channel is created when
the first record of its topic arrives, and is advertised to the browsers then.
Logging never waits for the network: the SDK puts a message on each subscribed
client's bounded queue and drops that client's oldest message when the queue is full
(`backlog`), so a slow browser loses old data and never holds the loop. A message of a
channel nobody subscribes to is not even encoded (counted `unwatched`).

Health: `sent` (messages handed to at least one subscriber), `unwatched`,
`rate_limited` (measurements over their channel's rate), `rejected.<reason>`
(`bad_time`, `unknown_record`, `malformed`, `unencodable`), `nonfinite_as_null`,
`errors.<what>` (`bind`, `channel`, `log`), `dropped.not_open`; info `url`, and in
the status `channels`, `clients` (subscribed to something), `subscriptions`.
A port that is taken fails `open()` with a message naming it (the runtime retries
with backoff) and is counted `errors.bind`.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any, ClassVar

import foxglove
from edged.channels import MAX_T, dumps, encode, to_ns
from edged.schemas import LOCATION_FIX, MESSAGE_ENCODING, SCHEMA_ENCODING, schema_bytes

from edged.plugin import OutputPlugin, PluginContext
from edged.ratelimit import DataTimeRateLimiter
from edged.records import Estimate, HealthRecord, Measurement, RawRecord

from .config import FoxgloveOutputConfig
from .listener import Subscriptions
from .ports import wait_released

__all__ = ["FoxgloveOutput", "STOP_TIMEOUT"]

#: Seconds close() waits for the stopped server to free its port (about 1 ms).
STOP_TIMEOUT = 2.0


class FoxgloveOutput(OutputPlugin):
    """Serves estimates, measurements, positions and health to Foxglove, live."""

    Config: ClassVar[type[FoxgloveOutputConfig]] = FoxgloveOutputConfig
    description: ClassVar[str] = "live Foxglove WebSocket server with the recording's channels"
    #: Raw records are recorded, never served: the router need not queue them here.
    exclude_keys: ClassVar[frozenset[str]] = frozenset({"raw"})

    def __init__(self, config: FoxgloveOutputConfig, ctx: PluginContext) -> None:
        super().__init__(config, ctx)
        self.config: FoxgloveOutputConfig = config
        self._limiter = DataTimeRateLimiter()
        self._meas_keys: dict[tuple[str, str], str] = {}  # (kind, source) -> its topic
        # Made at open (not picklable, and new for every run of the output):
        self._server: Any = None
        self._context: Any = None
        self._subs: Subscriptions | None = None
        self._channels: dict[str, Any] = {}  # topic -> foxglove.Channel
        self._refused: set[str] = set()  # topics the SDK refused a channel (counted once)

    # -- lifecycle -------------------------------------------------------------------
    async def open(self) -> None:
        """Start the server; OSError naming the address when it cannot listen."""
        cfg = self.config
        self._context = foxglove.Context()
        self._channels = {}
        self._refused = set()
        self._subs = Subscriptions(asyncio.get_running_loop())
        try:
            # (in a thread: a host name is looked up, which may take a while)
            self._server = await asyncio.to_thread(
                foxglove.start_server,
                name=f"edged {self.ctx.vessel_id}",
                host=cfg.host,
                port=cfg.port,
                context=self._context,
                server_listener=self._subs,
                message_backlog_size=cfg.backlog,
            )
        except (RuntimeError, OSError, ValueError) as exc:
            self._context = self._subs = None
            raise self._bind_failed(exc) from exc
        port = self._server.port
        self.ctx.health.info["url"] = f"ws://{self._shown_host()}:{port}"
        self.ctx.log.info("event=foxglove-listening url=ws://%s:%s", self._shown_host(), port)

    def _shown_host(self) -> str:
        h = self.config.host
        return f"[{h}]" if ":" in h else h

    def _bind_failed(self, exc: BaseException) -> OSError:
        where = f"{self._shown_host()}:{self.config.port}"
        why = str(exc).removeprefix("FoxgloveError: ")
        hint = " (another edged or Foxglove server? set another `port`)" if "in use" in why else ""
        message = f"foxglove: cannot listen on {where}: {why}{hint}"
        health = self.ctx.health
        health.count("errors.bind")
        health.error(message)
        health.info["url"] = None
        return OSError(message)

    @property
    def port(self) -> int | None:
        """The port the server listens on (the kernel's choice for port 0); None when closed."""
        return None if self._server is None else int(self._server.port)

    async def watched(self, topic: str, clients: int = 1) -> None:
        """Return once `clients` clients are subscribed to `topic` (tests, tools that
        must not publish before a browser listens; no timeout of its own)."""
        subs = self._subs
        if subs is None:
            raise RuntimeError("the Foxglove output is not open")
        await subs.until(lambda: subs.watchers(topic) >= clients)

    def watchers(self, topic: str) -> int:
        """Clients subscribed to `topic` now."""
        return 0 if self._subs is None else self._subs.watchers(topic)

    async def clients(self, n: int) -> None:
        """Return once exactly `n` clients are subscribed to something."""
        subs = self._subs
        if subs is None:
            raise RuntimeError("the Foxglove output is not open")
        await subs.until(lambda: subs.counts()["clients"] == n)

    async def close(self) -> None:
        """Stop the server and return once its port is free again (bounded)."""
        server, self._server = self._server, None
        for ch in self._channels.values():
            with contextlib.suppress(Exception):
                ch.close()
        self._channels = {}
        self._context = None
        self.ctx.health.info["url"] = None
        if server is None:
            return
        port = int(server.port)
        server.stop()
        if not await asyncio.to_thread(wait_released, self.config.host, port, STOP_TIMEOUT):
            self.ctx.log.warning("event=foxglove-stop port=%s reason='still held %g s after stop'", port, STOP_TIMEOUT)

    def status(self) -> dict[str, Any]:
        out: dict[str, Any] = {"channels": len(self._channels), "port": self.port}
        if self._subs is not None:
            out.update(self._subs.counts())
        return out

    # -- records ---------------------------------------------------------------------
    def write(self, batch: list[Any]) -> None:
        """Log each record's messages on its channels; never raises, never waits."""
        health = self.ctx.health
        if self._server is None:
            health.count("dropped.not_open", len(batch))
            return
        sent = unwatched = limited = 0
        for rec in batch:
            admitted = self._admit(rec)
            if admitted is None:
                continue
            if not admitted:
                limited += 1
                continue
            s, u = self._publish(rec)
            sent += s
            unwatched += u
        if sent:
            health.count("sent", sent)
        if unwatched:
            health.count("unwatched", unwatched)
        if limited:
            health.count("rate_limited", limited)

    def _admit(self, rec: Any) -> bool | None:
        """True: serve `rec`; False: over its channel's rate; None: not served here
        (switched off by the configuration, a raw record)."""
        cls = rec.__class__
        cfg = self.config
        if cls is Estimate:
            return True if cfg.estimates else None
        if cls is HealthRecord:
            return True if cfg.health else None
        if cls is RawRecord:
            return None  # recorded, never served (and not routed here: exclude_keys)
        if cls is not Measurement:
            return True  # unknown kinds of record are rejected (counted) by _publish
        if not (cfg.measurements or (cfg.locations and rec.kind == "position")):
            return None
        hz = cfg.hz(rec.kind)
        if hz <= 0.0:
            return None
        ck = (rec.kind, rec.source)
        key = self._meas_keys.get(ck)
        if key is None:
            key = self._meas_keys[ck] = f"/meas/{rec.kind}/{rec.source}"
        t = rec.t
        if not isinstance(t, (int, float)) or not 0.0 <= t < MAX_T:
            return True  # a bad time is rejected, counted, by _publish (the grid stays)
        return self._limiter.allow(key, t, hz)

    def _publish(self, rec: Any) -> tuple[int, int]:
        """Log the messages `rec` is recorded as; (sent, unwatched)."""
        health = self.ctx.health
        try:
            outs = encode(rec)
        except KeyError:
            return self._reject("unknown_record", f"not a record edged knows: {type(rec).__name__}")
        except (AttributeError, TypeError, ValueError) as exc:
            return self._reject("malformed", f"malformed {type(rec).__name__}: {type(exc).__name__}: {exc}")
        t = getattr(rec, "t", None)
        if not isinstance(t, (int, float)) or not 0.0 <= t < MAX_T:
            return self._reject("bad_time", f"record time outside the log-time range: {t!r} ({type(rec).__name__})")
        ns = to_ns(t)
        sent = unwatched = 0
        is_meas = rec.__class__ is Measurement
        for topic, schema, payload in outs:
            if is_meas and not (self.config.locations if schema == LOCATION_FIX else self.config.measurements):
                continue
            ch = self._channels.get(topic)
            if ch is None:
                if topic in self._refused:
                    continue
                ch = self._channel(topic, schema)
                if ch is None:
                    continue
            if not ch.has_sinks():
                unwatched += 1
                continue
            try:
                data, cleaned = dumps(payload)
            except (TypeError, ValueError) as exc:
                self._reject("unencodable", f"{topic}: not JSON: {exc}")
                continue
            if cleaned:
                health.count("nonfinite_as_null")
            try:
                ch.log(data, log_time=ns)
            except Exception as exc:  # (the SDK's own failure): counted, the loop goes on
                health.count("errors.log")
                health.error(f"foxglove log {topic}: {type(exc).__name__}: {exc}")
                continue
            sent += 1
        return sent, unwatched

    def _reject(self, reason: str, message: str) -> tuple[int, int]:
        self.ctx.health.count(f"rejected.{reason}")
        self.ctx.health.error(message)
        return 0, 0

    def _channel(self, topic: str, schema: str) -> Any:
        """The channel of `topic`, made (and advertised) now; None when the SDK refused."""
        try:
            sch = foxglove.Schema(name=schema, encoding=SCHEMA_ENCODING, data=schema_bytes(schema))
            ch = foxglove.Channel(topic, schema=sch, message_encoding=MESSAGE_ENCODING, context=self._context)
        except Exception as exc:  # a topic or schema the SDK refuses: counted, not served
            self.ctx.health.count("errors.channel")
            self.ctx.health.error(f"foxglove channel {topic}: {type(exc).__name__}: {exc}")
            self._refused.add(topic)
            return None
        self._channels[topic] = ch
        return ch
