"""`edged plot FILE.mcap [--truth truth.csv] -o report.png`: the pictures an analyst wants.

Track on a local map (equirectangular metres around the mean position), STW vs DVL vs
SOG, manoeuvring states, drafts and trim: each panel only when the recording has its
data (`drawing`, `panels`). matplotlib is an optional extra (`pip install 'edged[plot]'`).

With `--truth` (the simulator's `truth.csv`): per `/est/<name>` of kind `stw`, the
true STW on its panel, the error stw − truth with ±1/2/3 σ and the error's
autocorrelation at lags 0..120 samples. A truth file that is missing, not a truth table
or without `t` and `stw` columns is bad usage (exit 2, the message names it).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

from edged.recordings import RecordingError
from edged.registry import Registry
from edged.subcommand import EXIT_OK, EXIT_USAGE, Subcommand

from ..drawing import render
from ..plotdata import PlotData, collect
from ..stwdata import stw_error
from ..truth import ScoreError, Truth, read_truth
from edged.subcommand import existing_file, fail


def _have_matplotlib() -> bool:
    return importlib.util.find_spec("matplotlib") is not None


def _truth_notes(data: PlotData, truth: Truth, path: Path) -> list[str]:
    """What the user asked for with --truth and will not see, and why."""
    notes = []
    if truth.bad_rows:
        notes.append(f"{truth.name}: {truth.bad_rows} bad row(s) skipped (not numbers, no time or wrong number of cells)")
    usable = {n: s for n, s in data.stw.items() if s.has("stw")}
    if not usable:
        notes.append(f"{path}: no estimate of kind stw (/est/<name>): --truth {truth.name} not used")
    for name, s in usable.items():
        if not stw_error(s, truth).n:
            notes.append(f"{truth.name}: no truth at the times of est/{name}: its error is not drawn")
    return notes


def main(args: argparse.Namespace, registry: Registry | None = None) -> int:
    if not _have_matplotlib():
        return fail("plot needs matplotlib: pip install 'edged[plot]'")
    path = existing_file(args.file)
    if path is None:
        return EXIT_USAGE
    truth: Truth | None = None
    truth_arg = getattr(args, "truth", None)
    if truth_arg is not None:
        try:
            truth = read_truth(Path(truth_arg))
        except ScoreError as exc:
            return fail(str(exc), EXIT_USAGE)
    out = Path(args.output)
    try:
        data = collect(path, registry)
        if truth is not None:
            for note in _truth_notes(data, truth, path):
                print(f"edged: {note}", file=sys.stderr)
        panels = render(data, out, path.name, truth)
    except RecordingError as exc:
        return fail(f"{path}: {exc}")
    except OSError as exc:
        return fail(f"{exc.filename or out}: {exc.strerror or exc}")
    if not panels:
        return fail(f"{path}: nothing to plot (no positions, speeds, manoeuvre or draft data)")
    print(f"wrote {out}: {', '.join(panels)}", file=sys.stderr)
    return EXIT_OK


def arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE.mcap")
    p.add_argument("-o", "--output", required=True, metavar="report.png")
    p.add_argument("--truth", metavar="truth.csv",
                   help="truth table (the simulator's truth.csv): adds the STW error and its autocorrelation")


#: `edged plot` (entry point `edged.commands: plot`).
COMMAND = Subcommand("the pictures an analyst wants, as PNG", arguments, main)
