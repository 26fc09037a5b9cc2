"""Framing with bookkeeping: feeds bytes, returns accepted sentences, counts the rest.

Counters (in the input's ComponentHealth):
- `lines`: every line that is neither blank nor a `#` comment;
- `rejected.<reason>`: lines refused by `lines.frame` (see lines.REJECT_REASONS);
- `comments`: `#` lines (gpsd log headers), which are not errors.
The caller counts `accepted` (live: every framed line; replay: every line the stamper
could give a time, the others being `rejected.no_time`), so that
`lines == accepted + sum(rejected.*)` holds once a stream has been read.
"""

from __future__ import annotations

from itertools import repeat

from edged.health import ComponentHealth

from .lines import COMMENT, Framed, LineSplitter, frame, line_xors
from .reporting import ProblemReporter


class Framer:
    __slots__ = ("_health", "_policy", "_splitter", "_reporter", "_reject_keys")

    def __init__(self, health: ComponentHealth, policy: str = "require") -> None:
        self._health = health
        self._policy = policy
        self._splitter = LineSplitter()
        self._reporter = ProblemReporter(health)
        self._reject_keys: dict[str, str] = {}

    def feed(self, chunk: bytes) -> list[Framed]:
        return self._judge(self._splitter.feed(chunk))

    def flush(self) -> list[Framed]:
        return self._judge(self._splitter.flush())

    def reset(self) -> None:
        self._splitter.reset()

    def reject(self, reason: str) -> None:
        """Count a rejection; log the first of each reason."""
        key = self._reject_keys.get(reason)
        if key is None:
            key = self._reject_keys[reason] = "rejected." + reason
        self._health.count(key)
        self._reporter.report(f"rejected NMEA 0183 line: {reason}")

    def _judge(self, lines: list[bytes]) -> list[Framed]:
        out: list[Framed] = []
        policy = self._policy
        n_lines = 0
        n_comments = 0
        # Checksums for the whole chunk at once (a live port's few lines: one by one).
        xors = line_xors(lines) if policy != "ignore" else None
        for line, line_xor in zip(lines, repeat(None) if xors is None else xors):
            r = frame(line, policy, line_xor)
            if r is None:
                continue
            if type(r) is str:
                if r == COMMENT:
                    n_comments += 1
                    continue
                n_lines += 1
                self.reject(r)
                continue
            n_lines += 1
            out.append(r)  # type: ignore[arg-type]
        # Counted once per chunk: the hot path makes no per-line method calls here.
        if n_lines:
            self._health.count("lines", n_lines)
        if n_comments:
            self._health.count("comments", n_comments)
        return out
