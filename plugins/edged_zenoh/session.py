"""Opening a zenoh session from the event loop without ever failing the daemon.

`zenoh.open` can block (TLS handshakes, a connect timeout) and fails at once in client
mode when the router is down (DEPENDENCIES: unless `connect/timeout_ms` is -1, which
blocks forever instead). Both are wrong for a daemon on a ship whose shore link comes
and goes: `open_session` opens in a worker thread and retries with exponential backoff
until it succeeds or is cancelled, reporting its state in health.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any, Awaitable, Callable, Mapping

import zenoh

from edged.backoff import Backoff
from edged.health import ComponentHealth

from .zconfig import (
    ZenohSettings,
    endpoint_in_use,
    free_port_endpoint,
    listen_endpoints,
    session_config,
    to_zenoh,
    with_listen_endpoints,
)

__all__ = ["open_session", "close_session", "plugin_session_config", "open_plugin_session"]

Sleep = Callable[[float], Awaitable[None]]


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


async def open_session(
    cfg: Mapping[str, Any],
    health: ComponentHealth,
    log: logging.Logger,
    *,
    listen_fallback: bool = True,
    retry_initial: float = 0.5,
    retry_max: float = 30.0,
    sleep: Sleep = asyncio.sleep,
) -> tuple[zenoh.Session, dict[str, Any]]:
    """Open a session, retrying until it opens; returns it and the config it used.

    A listen port held by someone else is not worth waiting for: with
    `listen_fallback` the session moves to a free port at once (DESIGN §6). Every other
    failure (a router not up yet) is retried after `retry_initial` seconds, doubling up
    to `retry_max`. Health `info["zenoh"]` says `connecting` or `open`, and
    `info["listen"]` the endpoints actually listened on.
    """
    cfg = dict(cfg)
    zcfg = to_zenoh(cfg)  # a bad configuration is not retried: it will not heal
    backoff = Backoff(retry_initial, retry_max)
    health.info["zenoh"] = "connecting"
    while True:
        try:
            session = await _open_in_thread(zcfg)
        except zenoh.ZError as exc:
            moved = _fallback(cfg, log) if listen_fallback else None
            if moved is not None:
                cfg, zcfg = moved, to_zenoh(moved)
                health.count("listen_fallback")
                continue
            delay = backoff.next_delay()
            health.error(f"zenoh open failed (retrying): {exc}")
            health.info["zenoh_retry_in"] = delay
            health.count("open_retries")
            await sleep(delay)
            continue
        health.info.pop("zenoh_retry_in", None)
        health.info["zenoh"] = "open"
        health.info["listen"] = listen_endpoints(cfg)
        log.info("zenoh session %s open (mode %s, listening on %s)",
                 session.zid(), cfg.get("mode"), ", ".join(listen_endpoints(cfg)) or "nothing")
        return session, cfg


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


async def open_plugin_session(settings: ZenohSettings, ctx: Any, cfg: Mapping[str, Any]) -> zenoh.Session:
    """`open_session` with a plugin's health, log and retry settings."""
    session, _ = await open_session(
        cfg,
        ctx.health,
        ctx.log,
        listen_fallback=settings.listen_fallback,
        retry_initial=settings.retry_initial,
        retry_max=settings.retry_max,
    )
    return session
