"""edged: an edge daemon for a vessel's gateway computer (see DESIGN.md)."""

import multiprocessing as _mp
import signal as _signal
from importlib.metadata import PackageNotFoundError, version

# A process of the daemon's own (a recorder, an estimator worker: multiprocessing
# "spawn", named "edged-<instance>") imports this package first, while it unpickles
# what it is to run, long before its `serve`: numpy, pydantic and a filter stack take
# a second. A stop signal sent to the whole process group in that second (Ctrl-C,
# `systemctl stop`) killed it there, with a KeyboardInterrupt traceback (issue 32).
# The parent decides when its children end (`edged.signals.ignore_stop_signals`, whose
# CHILD_IGNORES these are: that module is not imported this early).
if _mp.current_process().name.startswith("edged-") and _mp.parent_process() is None and getattr(
        _mp.current_process(), "_inheriting", False):
    for _sig in (_signal.SIGINT, _signal.SIGTERM, _signal.SIGQUIT, _signal.SIGHUP, _signal.SIGUSR1, _signal.SIGUSR2):
        _signal.signal(_sig, _signal.SIG_IGN)

try:
    __version__ = version("edged")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"
