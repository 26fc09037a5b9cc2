"""Health: per-component state, counters, last error and rates.

Each plugin instance (and the router) owns one `ComponentHealth`. Counters are plain
dict increments (cheap enough for the hot path); state changes and new errors are
logged once per change, never once per message (DESIGN §8).
"""

from __future__ import annotations

import logging
from typing import Any

from .clock import Clock

log = logging.getLogger("edged.health")

#: States in which a component is doing its job. Plugins name their own states
#: (`connected`, `recording`, `stale`, `disk_full` ...); any state not listed here is
#: reported with `ok: false`, so a dashboard needs no list of every plugin's words.
OK_STATES = frozenset({"running", "connected", "recording", "finished"})
#: At most this many different errors of one component are logged per window (s).
ERROR_LOG_BURST = 5
ERROR_LOG_WINDOW = 60.0


class ComponentHealth:
    """State and counters of one component; see DESIGN §6 `health`."""

    __slots__ = (
        "name",
        "role",
        "type",
        "state",
        "counters",
        "last_error",
        "last_error_t",
        "restarts",
        "info",
        "problems",
        "_clock",
        "_prev",
        "_prev_t",
        "_log_window",
        "_logged",
        "_suppressed",
    )

    def __init__(self, name: str, role: str, type_: str, clock: Clock) -> None:
        self.name = name
        self.role = role
        self.type = type_
        self.state = "created"
        self.counters: dict[str, int] = {}
        self.last_error: str | None = None
        self.last_error_t: float | None = None
        self.restarts = 0
        self.info: dict[str, Any] = {}
        #: What is wrong while the component runs (an estimator whose sensor failed or
        #: whose innovations left their band): each names what it is about. Any
        #: problem makes the component `ok: false`, whatever its state.
        self.problems: list[str] = []
        self._clock = clock
        self._prev: dict[str, int] = {}
        self._prev_t: float | None = None
        self._log_window: float | None = None  # when the current error-log window began
        self._logged = 0  # errors logged in it
        self._suppressed = 0  # and left out of the log

    def count(self, key: str, n: int = 1) -> None:
        c = self.counters
        c[key] = c.get(key, 0) + n

    def set_state(self, state: str, reason: str | None = None) -> None:
        if state == self.state:
            return
        self.state = state
        extra = f" reason={reason!r}" if reason else ""
        log.info("component=%s role=%s state=%s%s", self.name, self.role, state, extra)

    def set_problems(self, problems: list[str]) -> None:
        """Replace the list of problems; logs when it changes (once per change)."""
        problems = [str(p) for p in problems]
        if problems == self.problems:
            return
        if problems:
            log.warning("component=%s role=%s problems=%r", self.name, self.role, problems)
        else:
            log.info("component=%s role=%s problems=resolved", self.name, self.role)
        self.problems = problems

    def error(self, message: str) -> None:
        """Record an error (`last_error`, counted `errors`). The one logging path of
        every plugin's errors, rate-limited: a message the same as the previous one is
        not logged again, and at most ERROR_LOG_BURST different ones per component in
        ERROR_LOG_WINDOW seconds; the next window begins with one line saying how many
        were left out. Why: a message that names its line (a gateway's garbage, an IMU
        saturating) is new every time: 133,764 log lines in 15 s from 2 MB/s of
        garbage (issue 32). The counters keep every one."""
        if message != self.last_error:
            now = self._clock.monotonic()
            if self._log_window is None or now - self._log_window >= ERROR_LOG_WINDOW:
                if self._suppressed:
                    log.warning("component=%s role=%s errors_not_logged=%d window_s=%g last_error=%r",
                                self.name, self.role, self._suppressed, ERROR_LOG_WINDOW, self.last_error)
                self._log_window, self._logged, self._suppressed = now, 0, 0
            if self._logged < ERROR_LOG_BURST:
                self._logged += 1
                log.warning("component=%s role=%s error=%r", self.name, self.role, message)
            else:
                self._suppressed += 1
        self.last_error = message
        self.last_error_t = self._clock.now()
        self.count("errors")

    def snapshot(self) -> dict[str, Any]:
        now = self._clock.monotonic()
        # One copy, kept as the next rates' base and published (neither is changed
        # after: a replay snapshots once a second of data, hundreds a wall second).
        counters = dict(self.counters)
        prev_t = self._prev_t
        if prev_t is not None and now > prev_t:
            dt = now - prev_t
            prev = self._prev
            rates = {k: round((v - prev.get(k, 0)) / dt, 3) for k, v in counters.items()}
        else:
            rates = {}
        self._prev = counters
        self._prev_t = now
        return {
            "role": self.role,
            "type": self.type,
            "state": self.state,
            "ok": self.state in OK_STATES and not self.problems,
            "problems": list(self.problems),
            "counters": counters,
            "rates": rates,
            "last_error": self.last_error,
            "last_error_t": self.last_error_t,
            "restarts": self.restarts,
            **({"info": dict(self.info)} if self.info else {}),
        }


class HealthRegistry:
    """All components' health; `snapshot()` is what outputs publish at 1 Hz."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        #: Every component there has been (the replay's summary reads them all).
        self.components: dict[str, ComponentHealth] = {}
        #: Those in the snapshot: all but the retired.
        self._live: dict[str, ComponentHealth] = {}

    def component(self, name: str, role: str, type_: str = "") -> ComponentHealth:
        """The component's health, made on first use; one retired comes back."""
        key = f"{role}:{name}"
        h = self._live.get(key)
        if h is None:
            h = self.components.get(key)
            if h is None:
                h = ComponentHealth(name, role, type_, self.clock)
                self.components[key] = h
            self._live[key] = h
        return h

    def retire(self, name: str, role: str) -> None:
        """Leave a component that has ended out of the snapshots (a replayed file read
        to its end): a replay of thousands of files would otherwise publish every
        one of them every second, a cost that grows with the square of the files.
        Its counters stay; `component()` brings it back."""
        self._live.pop(f"{role}:{name}", None)

    def snapshot(self) -> dict[str, Any]:
        out: dict[str, Any] = {"t": self.clock.now()}
        ok = True
        for h in self._live.values():
            snap = h.snapshot()
            ok = ok and snap["ok"]
            out.setdefault(h.role + "s", {})[h.name] = snap
        out["ok"] = ok
        return out
