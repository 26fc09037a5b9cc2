"""Structured log lines on stderr, journald-friendly.

One `key=value` line per event (state changes, errors, summaries), never one per
message at info level. Under systemd (JOURNAL_STREAM set) the timestamp is left to
journald; elsewhere each line starts with UTC time. SIGHUP reopens an optional log file.
"""

from __future__ import annotations

import logging
import logging.handlers
import os
import sys
import time

_FMT_PLAIN = "%(asctime)s level=%(levelname)s logger=%(name)s %(message)s"
_FMT_JOURNAL = "level=%(levelname)s logger=%(name)s %(message)s"


class _UTCFormatter(logging.Formatter):
    converter = time.gmtime

    def formatTime(self, record: logging.LogRecord, datefmt: str | None = None) -> str:
        return time.strftime("%Y-%m-%dT%H:%M:%S", self.converter(record.created)) + f".{int(record.msecs):03d}Z"


def setup_logging(level: str = "info", log_file: str | None = None) -> None:
    root = logging.getLogger()
    for h in list(root.handlers):
        root.removeHandler(h)
    fmt = _FMT_JOURNAL if os.environ.get("JOURNAL_STREAM") else _FMT_PLAIN
    handler: logging.Handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_UTCFormatter(fmt))
    root.addHandler(handler)
    if log_file:
        fh = logging.handlers.WatchedFileHandler(log_file)
        fh.setFormatter(_UTCFormatter(_FMT_PLAIN))
        root.addHandler(fh)
    root.setLevel(level.upper())


def reopen_logs() -> None:
    """SIGHUP: reopen log files that logrotate moved or removed.

    `WatchedFileHandler.reopenIfNeeded` reopens only when the file at the path is no
    longer the one open (moved, removed, replaced): exactly what logrotate's rename
    does, and a SIGHUP without a rotation keeps the open file.
    """
    for h in logging.getLogger().handlers:
        if isinstance(h, logging.handlers.WatchedFileHandler):
            h.acquire()  # emit() checks under the same lock
            try:
                h.reopenIfNeeded()
            finally:
                h.release()
