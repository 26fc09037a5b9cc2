"""`edged router` and `edged fleet` (entry point group `edged.commands`).

There is no zenohd binary on PyPI nor in Debian (DEPENDENCIES): a router for a ship or
a small shore site is a Python session in router mode, which is all `edged router` is.
Both commands use the same configuration path as the plugins: safe defaults, then the
json5 file of `--zenoh-config` merged over them. `edged fleet --record DIR` also
records every vessel's estimates and health (`fleetrecord`): its files are finished
when it stops (SIGINT, SIGTERM, SIGQUIT, SIGHUP; SIGUSR1/2 ignored), and it exits 1
when a recorder lost records.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import signal
import sys
import threading
from typing import Any, Iterable, Iterator, Mapping, TextIO

import zenoh

from edged.registry import Registry
from edged.subcommand import EXIT_FAILURE, EXIT_OK, EXIT_USAGE, Subcommand  # DESIGN §4

from .fleet import run_fleet
from .fleetrecord import MAX_VESSELS, FleetRecorder, FleetRecordError
from .zconfig import DEFAULT_LISTEN, ZenohConfigError, listen_endpoints, load_json5, merge, safe_defaults, to_zenoh

__all__ = ["router_main", "fleet_main", "run_router", "command_config", "ROUTER_DEFAULTS", "FLEET_DEFAULTS"]


#: A router on the ship's own loopback: the daemon and local tools meet here.
ROUTER_DEFAULTS = safe_defaults(mode="router")
#: A dashboard peer that listens on nothing and looks for the local router or daemon.
FLEET_DEFAULTS = safe_defaults(mode="peer", listen=(), connect=(DEFAULT_LISTEN,))


def command_config(defaults: Mapping[str, Any], zenoh_config: str | None) -> dict[str, Any]:
    """Defaults with the `--zenoh-config` file merged over them, checked by zenoh."""
    cfg = merge(defaults, load_json5(zenoh_config)) if zenoh_config else dict(defaults)
    to_zenoh(cfg, zenoh_config or "built-in defaults")
    return cfg


log = logging.getLogger("edged.fleet")

#: What stops a command: systemd's SIGTERM, a terminal's Ctrl-C.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def recording_stop_signals() -> tuple[signal.Signals, ...]:
    """What stops `edged fleet --record` with its files finished (DESIGN §4, as a
    replay): also Ctrl-\\ (SIGQUIT) and its terminal closing (SIGHUP, unless started
    with it ignored: `nohup`)."""
    sigs = [*STOP_SIGNALS, signal.SIGQUIT]
    if signal.getsignal(signal.SIGHUP) is not signal.SIG_IGN:
        sigs.append(signal.SIGHUP)
    return tuple(sigs)


@contextlib.contextmanager
def stop_on_signals(
    stop: threading.Event,
    signals: Iterable[signal.Signals] = STOP_SIGNALS,
    ignored: Iterable[signal.Signals] = (),
) -> Iterator[None]:
    """`signals` set `stop` (systemd stops with SIGTERM, a user with Ctrl-C); `ignored`
    are logged and ignored (their default would end the process, files unfinished)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: Any) -> None:
        stop.set()

    def ignore(signum: int, frame: Any) -> None:
        log.info("event=signal-ignored signal=%s", signal.Signals(signum).name)

    old = {s: signal.signal(s, handler) for s in signals}
    old.update({s: signal.signal(s, ignore) for s in ignored})
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def run_router(cfg: Mapping[str, Any], out: TextIO, stop: threading.Event) -> int:
    """Run a router session until `stop` is set; one line on `out` once it listens."""
    try:
        session = zenoh.open(to_zenoh(cfg))
    except zenoh.ZError as exc:
        print(f"edged router: cannot start: {exc}", file=sys.stderr)
        return EXIT_FAILURE
    try:
        eps = ", ".join(listen_endpoints(cfg)) or "nothing"
        print(f"edged router {session.zid()} listening on {eps}", file=out, flush=True)
        stop.wait()
    finally:
        session.close()
    print("edged router stopped", file=out, flush=True)
    return EXIT_OK


def router_main(args: argparse.Namespace, registry: Registry | None = None) -> int:
    try:
        cfg = command_config(ROUTER_DEFAULTS, getattr(args, "zenoh_config", None))
    except ZenohConfigError as exc:
        print(f"edged router: {exc}", file=sys.stderr)
        return EXIT_USAGE
    stop = threading.Event()
    with stop_on_signals(stop):
        return run_router(cfg, getattr(args, "out", None) or sys.stdout, stop)


def fleet_main(args: argparse.Namespace, registry: Registry | None = None) -> int:
    """`edged fleet [--record DIR]`; `args.out`, `duration`, `refreshes`, `interval` are
    optional (tests)."""
    try:
        cfg = command_config(FLEET_DEFAULTS, getattr(args, "zenoh_config", None))
    except ZenohConfigError as exc:
        print(f"edged fleet: {exc}", file=sys.stderr)
        return EXIT_USAGE
    record = getattr(args, "record", None)
    recorder = None
    if record:
        recorder = FleetRecorder(record)
        try:
            recorder.open()
        except FleetRecordError as exc:
            print(f"edged fleet: --record {record}: {exc}", file=sys.stderr)
            return EXIT_USAGE
        bound = "" if recorder.max_vessels == MAX_VESSELS else " (the open-file limit's)"
        print(f"edged fleet: recording into {recorder.directory}: one file per vessel and UTC day, "
              f"at most {recorder.max_vessels} vessels at once{bound}", file=sys.stderr)
    stop = threading.Event()
    signals = recording_stop_signals() if recorder is not None else STOP_SIGNALS
    ignored = (signal.SIGUSR1, signal.SIGUSR2) if recorder is not None else ()
    rc = EXIT_OK
    with stop_on_signals(stop, signals, ignored):
        try:
            rc = run_fleet(
                cfg,
                getattr(args, "out", None) or sys.stdout,
                interval=getattr(args, "interval", None) or 1.0,
                duration=getattr(args, "duration", None),
                refreshes=getattr(args, "refreshes", None),
                stop=stop,
                recorder=recorder,
            )
        except zenoh.ZError as exc:
            print(f"edged fleet: {exc}", file=sys.stderr)
            rc = EXIT_FAILURE
        finally:
            if recorder is not None:
                recorder.close()  # every file finished, whatever stopped the run
    if recorder is not None:
        print(f"edged fleet: {recorder.summary()}", file=sys.stderr)
        if recorder.losses and rc == EXIT_OK:
            rc = EXIT_FAILURE
    return rc


def router_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--zenoh-config", metavar="FILE.json5")


def fleet_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--zenoh-config", metavar="FILE.json5")
    p.add_argument("--record", metavar="DIR",
                   help="also record each vessel's estimates and health: DIR/<id>/<id>-<YYYY-MM-DD>.mcap (UTC days)")


#: `edged router` and `edged fleet` (entry points `edged.commands: router, fleet`).
ROUTER = Subcommand("a zenoh router for a ship or a small shore site", router_arguments, router_main)
FLEET = Subcommand("live table of every vessel under vessel/*", fleet_arguments, fleet_main)
