"""edged.logs: the log file is reopened on SIGHUP after logrotate moved it."""

from __future__ import annotations

import logging
import logging.handlers
from pathlib import Path

import pytest

from edged.logs import reopen_logs, setup_logging


@pytest.fixture
def log_file(tmp_path: Path):
    """setup_logging() with a log file; the root logger is restored afterwards."""
    root = logging.getLogger()
    saved = (list(root.handlers), root.level)
    path = tmp_path / "edged.log"
    setup_logging("info", str(path))
    try:
        yield path
    finally:
        for h in list(root.handlers):
            root.removeHandler(h)
            if isinstance(h, logging.FileHandler):
                h.close()
        for h in saved[0]:
            root.addHandler(h)
        root.setLevel(saved[1])


def test_a_moved_log_file_is_reopened_at_its_path(log_file: Path):
    log = logging.getLogger("edged.test")
    log.info("before rotation")
    rotated = log_file.with_name("edged.log.1")
    log_file.rename(rotated)  # what logrotate does, before it sends SIGHUP

    reopen_logs()
    assert log_file.exists()  # reopened by reopen_logs itself, not by the next line

    log.info("after rotation")
    assert "after rotation" in log_file.read_text()
    assert "before rotation" not in log_file.read_text()
    old = rotated.read_text()
    assert "before rotation" in old and "after rotation" not in old


def test_without_a_rotation_the_open_file_is_kept(log_file: Path):
    log = logging.getLogger("edged.test")
    log.info("one")
    (handler,) = [h for h in logging.getLogger().handlers if isinstance(h, logging.handlers.WatchedFileHandler)]
    stream = handler.stream
    reopen_logs()
    assert handler.stream is stream  # nothing moved: nothing reopened, nothing truncated
    log.info("two")
    text = log_file.read_text()
    assert "one" in text and "two" in text
