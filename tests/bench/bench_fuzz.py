"""Benchmark: the decoders' property-based fuzz tests with many more examples.

Run: .venv/bin/python tests/bench/bench_fuzz.py [N_EXAMPLES]   (default 20000)

Runs each fuzz test of the "values that cannot be true" hardening (issue 10) through
pytest with EDGED_FUZZ_EXAMPLES=N (the suite runs 200, same fixed seed), and prints
per test how many examples ran (Hypothesis' statistics) and how long it took. Exits 1
when a test fails: a counterexample is a decoder emitting a value that cannot be true.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

TESTS = (
    "tests/nmea0183/test_hardening_values.py::test_fuzz_every_sentence_type_emits_only_true_values",
    "tests/can/test_hardening_values.py::test_fuzz_every_handled_pgn_emits_only_true_values",
    "tests/nmea0183/test_hardening_time.py::test_whatever_the_tag_times_every_record_time_is_finite_and_representable",
    "tests/can/test_hardening_candump.py::test_whatever_the_lines_every_record_is_sound",
    "tests/mcap/test_hardening_files.py::test_fuzz_the_replay_reading_path",
    "tests/can/test_log_line_bound.py::test_fuzz_whatever_the_lines_every_reader_bounds_them",
)

# "- during generate phase (12.34 seconds):" ... "- 20000 passing, 0 failing, and 15 invalid
# test cases" (older Hypothesis: "20000 passing examples, 0 failing examples, ...")
_PHASE = re.compile(r"during (\w+) phase")
_COUNTS = re.compile(r"(\d+) passing(?: examples?)?, (\d+) failing")


def run(test: str, examples: int) -> tuple[bool, int, int, float]:
    env = dict(os.environ, EDGED_FUZZ_EXAMPLES=str(examples))
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--hypothesis-show-statistics", test],
        cwd=REPO, env=env, capture_output=True, text=True,
    )
    wall = time.perf_counter() - t0
    passing = failing = 0
    phase = None
    for line in proc.stdout.splitlines():
        m = _PHASE.search(line)
        if m:
            phase = m.group(1)
        m = _COUNTS.search(line)
        if m and phase in ("explicit", "reuse", "generate"):
            passing += int(m.group(1))
            failing += int(m.group(2))
    if proc.returncode != 0:
        sys.stdout.write(proc.stdout[-4000:] + proc.stderr[-2000:])
    return proc.returncode == 0, passing, failing, wall


def main() -> int:
    examples = int(sys.argv[1]) if len(sys.argv) > 1 else 20000
    ok_all = True
    total = 0
    for test in TESTS:
        ok, passing, failing, wall = run(test, examples)
        ok_all &= ok
        total += passing + failing
        name = test.split("::")[1]
        rate = (passing + failing) / wall if wall > 0 else 0.0
        print(f"{name}: {'ok' if ok else 'FAILED'}, {passing} examples passed, {failing} failed, "
              f"{wall:.1f} s ({rate:.0f} examples/s, pytest start-up included)")
    print(f"total: {total} examples ({examples} asked per test)")
    return 0 if ok_all else 1


if __name__ == "__main__":
    sys.exit(main())
