"""`edged score FILE.mcap --truth truth.csv`: estimates against truth (DESIGN §4).

Per scored field of every `/est/<name>` channel (`edged.estimates`: its truth column,
σ and the sensor it replaces): n, RMSE, bias, max |error|, the share of errors inside
±1/2/3σ and the error autocorrelation at lags 1, 10 and 60 samples (ESTIMATORS
"Evaluation": a consistent filter covers 68/95/99.7 % and its converged error is
white). The raw sensor rows sit indented under their field, judged by the same rules,
so that "better than the sensor" is read off one table; so do the derived baselines
(under `stw`: "naive: sog - forecast along course", SOG − the latest current forecast
along COG, one row per GNSS and current source pair, none without currents). The
figures are in `edged_analysis.figures`, the truth.csv format in `edged_analysis.truth`.

Output: a fixed-width table on stdout, or with `--json` one JSON list of rows (null
where a figure does not apply). Notes (unscorable kinds, missing truth columns, bad
truth rows, a damaged recording) go to stderr.

Exit codes (DESIGN §4): 2 for bad usage or input files (missing, not a recording, not
a truth table, no estimates, no overlapping time, nothing left after the warm-up), 1
for a runtime failure (an I/O error; also, without a message, a reader that closed the
pipe early), 0 otherwise; always a one-line message naming the file, never a traceback.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

from edged.recordings import RecordingError, RecordingReport
from edged.registry import Registry
from edged.subcommand import EXIT_FAILURE, EXIT_OK, EXIT_USAGE, Subcommand

from ..recording import Recording, read_recording
from ..scoretable import render
from ..scoring import score
from ..truth import ScoreError, Truth, load_truth
from edged.subcommand import existing_file, fail


def _damage_notes(path: Path, report: RecordingReport, rec: Recording) -> list[str]:
    """What a damaged or unfinished file cost: scored anyway, from what was readable."""
    notes = []
    if not report.finished:
        notes.append(f"{path}: unfinished recording ({report.unfinished_why}); scored what was readable")
    if report.bad_chunks:
        notes.append(f"{path}: {report.bad_chunks} damaged chunk(s) skipped")
    if report.orphans:
        notes.append(f"{path}: {report.orphans} message(s) without a channel skipped")
    if rec.undecodable:
        notes.append(f"{path}: {rec.undecodable} message(s) that are not JSON objects with a time skipped")
    return notes


def _emit(text: str) -> int:
    """Write the result (a reader that went away is `command`'s to report)."""
    sys.stdout.write(text)
    return EXIT_OK


def _os_error(path: Path, exc: OSError) -> int:
    """An unreadable input is the user's to fix (2); any other I/O error is a failure (1)."""
    code = EXIT_USAGE if isinstance(exc, (PermissionError, IsADirectoryError)) else EXIT_FAILURE
    return fail(f"{exc.filename or path}: {exc.strerror or exc}", code)


def _inputs(args: argparse.Namespace, registry: Registry) -> tuple[Truth, Recording, RecordingReport] | int:
    """The truth table and the recording, or the exit code after saying what is wrong."""
    path = existing_file(args.file)
    if path is None:
        return EXIT_USAGE
    truth_path = existing_file(args.truth)
    if truth_path is None:
        return EXIT_USAGE
    try:
        with open(truth_path, encoding="utf-8-sig", newline="") as f:
            truth = load_truth(f, str(truth_path))
    except ScoreError as exc:
        return fail(str(exc), EXIT_USAGE)
    except OSError as exc:
        return _os_error(truth_path, exc)
    try:
        rec, report = read_recording(path, registry)
    except RecordingError as exc:
        return fail(f"{path}: {exc}", EXIT_USAGE)
    except OSError as exc:
        return _os_error(path, exc)
    return truth, rec, report


def main(args: argparse.Namespace, registry: Registry | None = None) -> int:
    warmup = args.warmup
    if not (isinstance(warmup, (int, float)) and math.isfinite(warmup) and warmup >= 0):
        return fail(f"--warmup: {warmup!r} is not a non-negative number of seconds", EXIT_USAGE)
    inputs = _inputs(args, registry or Registry())
    if isinstance(inputs, int):
        return inputs
    truth, rec, report = inputs
    path = Path(args.file)
    notes = _damage_notes(path, report, rec)
    if truth.bad_rows:
        notes.append(f"{truth.name}: {truth.bad_rows} bad row(s) skipped (not numbers, no time or wrong number of cells)")
    try:
        result = score(rec, truth, float(warmup), args.estimate)
    except ScoreError as exc:
        for n in notes:
            print(f"edged: {n}", file=sys.stderr)
        return fail(str(exc), EXIT_USAGE)
    except Exception as exc:  # noqa: BLE001 - the CLI contract: a message and 1, never a traceback
        return fail(f"{path}: scoring failed: {type(exc).__name__}: {exc}", EXIT_FAILURE)
    for n in notes + result.notes:
        print(f"edged: {n}", file=sys.stderr)
    if args.json:
        doc: list[dict[str, Any]] = [r.to_json() for r in result.rows]
        return _emit(json.dumps(doc, indent=1) + "\n")
    return _emit(render(result.rows))


def arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE.mcap")
    p.add_argument("--truth", required=True, metavar="truth.csv", help="truth table (the simulator's truth.csv columns)")
    p.add_argument("--warmup", type=float, default=60.0, metavar="S", help="seconds after the first estimate left out (default 60)")
    p.add_argument("--estimate", action="append", metavar="NAME", help="only these estimates (est/NAME); repeatable")
    p.add_argument("--json", action="store_true", help="the figures as JSON instead of a table")


#: `edged score` (entry point `edged.commands: score`).
COMMAND = Subcommand("estimates of a recording against truth: RMSE, bias, σ coverage", arguments, main)
