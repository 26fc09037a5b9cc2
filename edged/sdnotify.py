"""systemd's notify protocol (sd_notify(3)): ready, watchdog, status, stopping.

Under `Type=notify` the service manager waits for `READY=1` before it counts the daemon
as started, and with `WatchdogSec=` it restarts a daemon that has not sent
`WATCHDOG=1` within that time. The protocol is one datagram of `KEY=value` lines to the
AF_UNIX socket named by `$NOTIFY_SOCKET` (a leading `@` names the abstract namespace);
the period is `$WATCHDOG_USEC` microseconds, meant for this process when
`$WATCHDOG_PID` is unset or equal to our pid. Why our own few lines rather than a
package: the `sdnotify` package (last release 2017) swallows every error and has no
watchdog period; `systemd-python` needs libsystemd's headers to build. Outside systemd
(`$NOTIFY_SOCKET` unset) every call does nothing.

The watchdog is fed by a task of the event loop (`feed_watchdog`) and only while every
task the runtime supervises (inputs, workers, outputs) is alive: a loop that is held (a
step that never returns) or a plugin task that ended for good stops the feeding, and
systemd restarts the daemon. A sensor that is merely silent or unplugged does not: its
input reconnects on its own, and restarting the daemon would not bring it back.
"""

from __future__ import annotations

import asyncio
import logging
import os
import socket
from typing import Awaitable, Callable, Iterable, Mapping

__all__ = ["Notifier", "watchdog_period", "feed_watchdog"]

log = logging.getLogger("edged.sdnotify")


class Notifier:
    """Sends notifications to the service manager; a no-op without `$NOTIFY_SOCKET`."""

    def __init__(self, address: str | None = None, env: Mapping[str, str] | None = None) -> None:
        env = os.environ if env is None else env
        self.address = address if address is not None else env.get("NOTIFY_SOCKET") or None
        self._sock: socket.socket | None = None
        self._failed = False

    @property
    def enabled(self) -> bool:
        return self.address is not None

    def _target(self) -> str | bytes:
        assert self.address is not None
        if self.address.startswith("@"):
            return b"\0" + self.address[1:].encode()
        return self.address

    def send(self, **fields: object) -> bool:
        """One notification of `fields` (e.g. READY=1, STATUS="..."); True when sent."""
        if self.address is None:
            return False
        text = "\n".join(f"{k}={v}" for k, v in fields.items()) + "\n"
        try:
            if self._sock is None:
                self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)
            self._sock.sendto(text.encode(), self._target())
        except OSError as exc:
            if not self._failed:  # said once: a manager that went away must not flood the log
                log.warning("event=notify-failed socket=%r error=%r", self.address, str(exc))
                self._failed = True
            return False
        self._failed = False
        return True

    def ready(self, status: str = "") -> bool:
        return self.send(READY=1, **({"STATUS": status} if status else {}))

    def watchdog(self) -> bool:
        return self.send(WATCHDOG=1)

    def status(self, text: str) -> bool:
        return self.send(STATUS=text)

    def stopping(self) -> bool:
        return self.send(STOPPING=1)

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None


def watchdog_period(env: Mapping[str, str] | None = None, pid: int | None = None) -> float | None:
    """The watchdog period systemd asks of this process (seconds), or None when it asks
    none (no `WatchdogSec=`, or the request is for another pid)."""
    env = os.environ if env is None else env
    usec = env.get("WATCHDOG_USEC")
    if not usec:
        return None
    want_pid = env.get("WATCHDOG_PID")
    if want_pid and want_pid != str(pid if pid is not None else os.getpid()):
        return None
    try:
        period = int(usec) / 1e6
    except ValueError:
        log.warning("event=watchdog-ignored WATCHDOG_USEC=%r reason='not an integer'", usec)
        return None
    return period if period > 0 else None


async def feed_watchdog(
    notifier: Notifier,
    period: float,
    dead: Callable[[], Iterable[str]],
    sleep: Callable[[float], Awaitable[object]] = asyncio.sleep,
) -> None:
    """`WATCHDOG=1` every half period (sd_watchdog_enabled(3) advises it) while `dead()`
    names no task; the first time it names some, said once (the restart that follows
    is then explained in the journal), and the feeding stops until none is dead."""
    said: frozenset[str] = frozenset()
    while True:
        await sleep(period / 2.0)
        gone = frozenset(dead())
        if gone:
            if gone != said:
                log.error("event=watchdog-withheld tasks=%s reason='ended for good: systemd restarts the daemon'",
                          ",".join(sorted(gone)))
                said = gone
            continue
        said = frozenset()
        notifier.watchdog()
