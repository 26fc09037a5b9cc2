"""`edged sim SCENARIO --out DIR [--duration S] [--seed N] [--waves SPEC]` (DESIGN §4).

SCENARIO is a named scenario or a composition `VESSEL:SUITE[:FAULT]` (`grid.py`: a
vessel, a sensor suite and a sensor fault, e.g. `tanker:fog`, `yacht:yacht:heading-frozen`).
`--waves` replaces the scenario's sea (`waves.parse_waves`); meta.json records the sea
that was used and the option as given (`overrides`).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from edged.registry import Registry
from edged.subcommand import EXIT_FAILURE, EXIT_OK, EXIT_USAGE, Subcommand, seed  # DESIGN §4

from .run import Simulation
from .grid import help_text
from .scenarios import SCENARIOS, lookup
from .waves import parse_waves
from .writers import write_run


def main(args: argparse.Namespace, registry: Registry | None = None) -> int:
    try:
        scenario = lookup(args.scenario)
    except ValueError as exc:
        names = "\n".join(f"  {n:24s} {s.description}" for n, s in SCENARIOS.items())
        print(f"edged sim: {exc}; scenarios:\n{names}\n{help_text()}", file=sys.stderr)
        return EXIT_USAGE
    duration = getattr(args, "duration", None)
    if duration is not None and not duration > 0:
        print(f"edged sim: --duration must be positive, got {duration}", file=sys.stderr)
        return EXIT_USAGE
    overrides: dict[str, str] = {}
    waves = getattr(args, "waves", None)
    if waves is not None:
        try:
            sea = parse_waves(waves, getattr(scenario.waves, "from_deg", 0.0))
        except ValueError as exc:
            print(f"edged sim: --waves: {exc}", file=sys.stderr)
            return EXIT_USAGE
        scenario = replace(scenario, waves=sea)
        overrides["waves"] = waves
    out = Path(args.out)
    sim = Simulation(scenario, seed=int(getattr(args, "seed", 0) or 0), duration=duration, overrides=overrides)
    try:
        meta = write_run(sim, out)
    except OSError as exc:
        print(f"edged sim: cannot write {out}: {exc}", file=sys.stderr)
        return EXIT_FAILURE
    files = ", ".join(f"{k} {v}" for k, v in meta["files"].items())
    print(f"{scenario.name}: {sim.duration:.0f} s, seed {sim.seed} -> {out} ({files})")
    return EXIT_OK


def arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", metavar="SCENARIO")
    p.add_argument("--out", required=True, metavar="DIR")
    p.add_argument("--duration", type=float, default=None, metavar="S")
    p.add_argument("--seed", type=seed, default=0, metavar="N")
    p.add_argument("--waves", metavar="SPEC", default=None,
                   help="the sea instead of the scenario's: regular:AMPLITUDE,PERIOD[,FROM_DEG] or "
                        "jonswap:HS,TP[,FROM_DEG] (m, s, degrees true; FROM_DEG defaults to the scenario's)")


#: `edged sim` (entry point `edged.commands: sim`).
COMMAND = Subcommand("simulate a vessel and write its sensor logs and truth", arguments, main)
