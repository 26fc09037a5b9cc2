"""`edged recover FILE.mcap`: write FILE.recovered.mcap beside it, never alter FILE."""

from __future__ import annotations

import argparse

from mcap.exceptions import McapError

from edged.registry import Registry
from edged.subcommand import EXIT_FAILURE, EXIT_OK, EXIT_USAGE, existing_file, fail, Subcommand

from ..recovery import recover

def main(args: argparse.Namespace, registry: Registry | None = None) -> int:
    src = existing_file(args.file)
    if src is None:
        return EXIT_USAGE
    try:
        res = recover(src)
    except McapError as exc:
        return fail(f"{src}: {exc}")
    except OSError as exc:
        return fail(f"{exc.filename or src}: {exc.strerror or exc}")
    r = res.report
    state = "was complete" if r.healthy else "was unfinished" if r.truncated or not r.finished else "was damaged"
    print(f"{src} {state}: {res.messages} messages on {res.channels} channels in {r.chunks} complete chunks")
    if r.bad_chunks:
        print(f"skipped {r.bad_chunks} damaged chunk(s): {r.bad_chunk_errors[0]}")
    if r.error:
        print(f"stopped reading at: {r.error}")
    print(f"wrote {res.output}")
    return EXIT_OK if res.messages or r.finished else EXIT_FAILURE


def arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE.mcap")


#: `edged recover` (entry point `edged.commands: recover`).
COMMAND = Subcommand("make an unfinished recording valid again", arguments, main)
