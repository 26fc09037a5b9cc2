"""Opening a zenoh session from the event loop without ever failing the daemon.

`zenoh.open` can block (TLS handshakes, a connect timeout) and fails at once in client
mode when the router is down (DEPENDENCIES: unless `connect/timeout_ms` is -1, which
blocks forever instead). Both are wrong for a daemon on a ship whose shore link comes
and goes: a session is opened in a worker thread (`SessionOpener`) and retried with
exponential backoff by the link every input shares (`edged.link.Link`, `session_link`)
until it succeeds or is cancelled, reporting its state and counters in health.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any, Mapping

import zenoh

from edged.backoff import Backoff
from edged.health import ComponentHealth
from edged.link import Link, Sleep

from .zconfig import (
    ZenohSettings,
    endpoint_in_use,
    free_port_endpoint,
    listen_endpoints,
    session_config,
    to_zenoh,
    with_listen_endpoints,
)

__all__ = [
    "SessionOpener",
    "session_link",
    "open_session",
    "close_session",
    "plugin_session_config",
    "plugin_session_link",
    "open_plugin_session",
]

def _fallback(cfg: Mapping[str, Any], log: logging.Logger) -> dict[str, Any] | None:
    """The config with every taken listen port replaced by a free one, or None."""
    eps = listen_endpoints(cfg)
    taken = [ep for ep in eps if endpoint_in_use(ep)]
    if not taken:
        return None
    new = [free_port_endpoint(ep) if ep in taken else ep for ep in eps]
    for old, ep in zip(eps, new):
        if old != ep:
            log.warning("zenoh listen endpoint %s is taken: listening on %s instead", old, ep)
    return with_listen_endpoints(cfg, new)


def _close_opened(fut: "asyncio.Future[zenoh.Session]") -> None:
    if not fut.cancelled() and fut.exception() is None:
        fut.result().close()


async def _open_in_thread(zcfg: zenoh.Config) -> zenoh.Session:
    """`zenoh.open` in a thread; a session that opens after we were cancelled is closed."""
    fut = asyncio.ensure_future(asyncio.to_thread(zenoh.open, zcfg))
    try:
        return await asyncio.shield(fut)
    except asyncio.CancelledError:
        fut.add_done_callback(_close_opened)
        raise


class SessionOpener:
    """One attempt at opening a session, for `edged.link.Link` to retry.

    A listen port held by someone else is not worth waiting for: with
    `listen_fallback` the attempt moves to a free port at once (DESIGN §6) and the
    configuration it used is kept in `cfg` for the next attempts. Every other failure
    (a router not up yet) raises `zenoh.ZError`: the link retries after its backoff.
    """

    def __init__(self, cfg: Mapping[str, Any], health: ComponentHealth, log: logging.Logger, *,
                 listen_fallback: bool = True) -> None:
        self.cfg = dict(cfg)
        self._zcfg = to_zenoh(self.cfg)  # a bad configuration is not retried: it will not heal
        self._health = health
        self._log = log
        self._listen_fallback = listen_fallback

    async def __call__(self) -> zenoh.Session:
        while True:
            try:
                session = await _open_in_thread(self._zcfg)
            except zenoh.ZError:
                moved = _fallback(self.cfg, self._log) if self._listen_fallback else None
                if moved is None:
                    raise
                self.cfg, self._zcfg = moved, to_zenoh(moved)
                self._health.count("listen_fallback")
                continue
            eps = listen_endpoints(self.cfg)
            self._health.info["listen"] = eps
            self._log.info("zenoh session %s open (mode %s, listening on %s)",
                           session.zid(), self.cfg.get("mode"), ", ".join(eps) or "nothing")
            return session


def session_link(
    health: ComponentHealth,
    *,
    retry_initial: float = 0.5,
    retry_max: float = 30.0,
    sleep: Sleep = asyncio.sleep,
    info_key: str | None = None,
) -> Link[zenoh.Session]:
    """The `edged.link.Link` of a zenoh session: retried after `retry_initial` seconds,
    doubling up to `retry_max`; counters and states those of every edged link."""
    return Link(
        health,
        Backoff(retry_initial, retry_max),
        where="zenoh session",
        sleep=sleep,
        open_errors=(zenoh.ZError,),
        link_errors=(),
        info_key=info_key,
    )


async def open_session(
    cfg: Mapping[str, Any],
    health: ComponentHealth,
    log: logging.Logger,
    *,
    listen_fallback: bool = True,
    retry_initial: float = 0.5,
    retry_max: float = 30.0,
    sleep: Sleep = asyncio.sleep,
    info_key: str | None = "zenoh",
) -> tuple[zenoh.Session, dict[str, Any]]:
    """Open a session, retrying until it opens; returns it and the config it used.

    The link state (`connecting`, `disconnected` while waiting to retry, `connected`)
    goes to health `info[info_key]` (default `info["zenoh"]`: the output, whose own
    state is its recording's), or with `info_key=None` is the component's state;
    `info["listen"]` holds the endpoints actually listened on.
    """
    opener = SessionOpener(cfg, health, log, listen_fallback=listen_fallback)
    link = session_link(health, retry_initial=retry_initial, retry_max=retry_max, sleep=sleep, info_key=info_key)
    session = await link.open(opener)
    return session, opener.cfg


async def close_session(session: zenoh.Session | None) -> None:
    """Close in a thread: closing flushes and says goodbye to peers, which may wait."""
    if session is not None and not session.is_closed():
        await asyncio.shield(asyncio.to_thread(session.close))


def plugin_session_config(settings: ZenohSettings, ctx: Any, base: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The session configuration of a plugin (input or output): its settings, its
    json5 file and `--zenoh-config`, over `base`; checked by zenoh (ZenohConfigError)."""
    cfg = session_config(settings, config_dir=ctx.config_dir, cli_file=ctx.options.get("zenoh_config"), base=base)
    to_zenoh(cfg)
    return cfg


def plugin_session_link(settings: ZenohSettings, ctx: Any, *, info_key: str | None = None) -> Link[zenoh.Session]:
    """`session_link` with a plugin's health and retry settings."""
    return session_link(ctx.health, retry_initial=settings.retry_initial, retry_max=settings.retry_max, info_key=info_key)


async def open_plugin_session(settings: ZenohSettings, ctx: Any, cfg: Mapping[str, Any]) -> zenoh.Session:
    """`open_session` with a plugin's health, log and retry settings (link state in
    `info["zenoh"]`)."""
    session, _ = await open_session(
        cfg,
        ctx.health,
        ctx.log,
        listen_fallback=settings.listen_fallback,
        retry_initial=settings.retry_initial,
        retry_max=settings.retry_max,
    )
    return session
