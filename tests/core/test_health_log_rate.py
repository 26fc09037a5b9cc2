"""One rate-limited logging path for every plugin's errors (issue 32).

Garbage to an n2k gateway gave one WARNING per bad line, because the line was in the
message: 133,764 log lines (42 MB) in 15 s. `ComponentHealth.error` now logs at most
ERROR_LOG_BURST different errors per component per ERROR_LOG_WINDOW seconds and says
how many it left out; the counters keep every one."""

from __future__ import annotations

import logging

import pytest

from edged.clock import ManualClock
from edged.health import ERROR_LOG_BURST, ERROR_LOG_WINDOW, ComponentHealth


@pytest.mark.parametrize("n", [ERROR_LOG_BURST + 1, 1000, 100_000])
def test_a_flood_of_different_errors_is_a_few_log_lines_and_every_count(n, caplog):
    clock = ManualClock(1_700_000_000.0)
    h = ComponentHealth("gw", "input", "n2k_gateway", clock)
    with caplog.at_level(logging.WARNING, logger="edged.health"):
        for k in range(n):
            h.error(f"line {k}: not a gateway line: {k!r}")
        first = [r.getMessage() for r in caplog.records]
        clock.step(ERROR_LOG_WINDOW)
        h.error("line -1: the next window's first error")
    lines = [r.getMessage() for r in caplog.records]
    assert len(first) == ERROR_LOG_BURST
    assert f"errors_not_logged={n - ERROR_LOG_BURST}" in lines[ERROR_LOG_BURST]
    assert "the next window's first error" in lines[-1] and len(lines) == ERROR_LOG_BURST + 2
    assert h.counters["errors"] == n + 1
    assert h.last_error == "line -1: the next window's first error"


def test_the_same_error_again_is_not_logged_again(caplog):
    h = ComponentHealth("gw", "input", "n2k_gateway", ManualClock(0.0))
    with caplog.at_level(logging.WARNING, logger="edged.health"):
        for _ in range(100):
            h.error("IMU saturated")
    assert len(caplog.records) == 1 and h.counters["errors"] == 100
