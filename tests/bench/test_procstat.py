"""The benchmarks' reading of /proc (tests/bench/procstat.py): a run's whole tree."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import procstat  # noqa: E402


def test_the_tree_of_a_run_holds_its_children_and_their_memory():
    code = "import subprocess, sys; subprocess.run([sys.executable, '-c', 'import sys; sys.stdin.read()'])"
    run = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 60  # a bound, not a wait: looks until the grandchild exists
        members = procstat.tree(run.pid)
        while len(members) < 2 and time.monotonic() < deadline:
            members = procstat.tree(run.pid)
        assert run.pid in members and len(members) == 2
        assert all(procstat.rss(p) > 0 for p in members)
        assert procstat.cpu_seconds(run.pid) is not None
        assert os.getpid() not in members
    finally:
        run.stdin.close()
        run.wait(30)
    assert procstat.stat(run.pid) is None and procstat.rss(run.pid) == 0
