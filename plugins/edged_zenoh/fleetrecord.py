"""`edged fleet --record DIR`: the shore-side history, one MCAP file per vessel per UTC day.

Every sample `edged fleet` receives under `vessel/<id>/est/<name>` and
`vessel/<id>/health` is turned back into the record the vessel published
(`fromjson`: an `Estimate`, a `HealthRecord`) and handed to an MCAP recorder, so that a
shore file has the very channels and payloads of a recording made on board
(`/est/<name>` with schema `edged.est.<kind>`, `/health`; DESIGN §7) and `edged
inspect/export/plot/score` read it alike. The recorder is the installed output plugin
of type `mcap`, found through the registry (a plugin does not import another's
package), one instance per vessel, its `path` that vessel's file of the day:

    DIR/<vessel id>/<vessel id>-<YYYY-MM-DD>.mcap

- The day is the UTC day of the sample's data time `t`. A sample of a later day
  finishes the file and opens the next day's; a sample up to `LATE_GRACE` seconds
  before the current day began (a health snapshot of 23:59:59.9 that arrives after an
  estimate of 00:00:00.1) goes into the current file (`late_for_day`); an older one (a
  vessel whose clock was set back) opens a file of its own day.
- A file of that name already there (`edged fleet` started again the same day, a vessel
  back after `IDLE_FINISH`) is never overwritten: the next is `<id>-<day>_2.mcap`, ...
  Past the recorder's chunk-index bound a file goes on in `<stem>.001.mcap` (the
  recorder's own numbering).
- A vessel id that is not a name of DESIGN (letters, digits, `_ - .`, not beginning
  with `.` or `-`, at most 128 characters) is never a path component: its samples are
  refused, counted `refused.bad_vessel_id`, the id logged once. So are the samples of
  a new vessel while `max_vessels` (1000) are recorded (`refused.too_many_vessels`),
  of a vessel past `MAX_KEYS` keys (`rejected.too_many_keys`), and payloads that are
  no record (`rejected.<reason>`, `fromjson`). A sample whose key and `t` were taken
  just before (the query at start, then the same sample from the subscription) is
  counted `duplicates` and written once.
- `flush()` (about once a second, by `run_fleet`) flushes the files that took
  samples since the last one (the recorder fsyncs: a crash loses about a second), and
  finishes the file of a vessel silent for `IDLE_FINISH` seconds, freeing its place.
  `close()` finishes every file (Ctrl-C, SIGTERM, the end of a bounded run).

Calls come from one thread, not an event loop's (the recorder's `open`/`close` are
coroutines, run on a private loop).
"""

from __future__ import annotations

import asyncio
import logging
import os
from collections import Counter, deque
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Mapping

from edged.clock import Clock, LiveClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged.registry import PluginNotFound, Registry

from .fromjson import NotARecord, record_from_json, valid_name

__all__ = [
    "FleetRecorder",
    "FleetRecordError",
    "day_file",
    "MAX_VESSELS",
    "MAX_KEYS",
    "IDLE_FINISH",
    "LATE_GRACE",
    "RECORDER_TYPE",
]

log = logging.getLogger("edged.fleet.record")

PREFIX = "vessel"
#: The output plugin type that records (DESIGN §7), as `edged replay --record` uses.
RECORDER_TYPE = "mcap"
#: Vessels recorded at once (each holds an open file and its chunk buffer).
MAX_VESSELS = 1000
#: Keys (est/<name>, health) of one vessel taken: each is a channel of its files.
MAX_KEYS = 256
#: Seconds (of the fleet's own monotonic clock) without a sample after which a
#: vessel's file is finished and its place freed.
IDLE_FINISH = 3600.0
#: Seconds before the current day's start a straggler still goes into its file.
LATE_GRACE = 300.0
#: Files of one vessel and day at most (`_2` ... `_999`).
MAX_FILES_PER_DAY = 999
#: The last data times per key remembered to drop a sample taken twice.
RECENT = 8
#: File descriptors left for everything else (zenoh's sockets, logs).
FD_RESERVE = 256
#: Refused vessel ids named in the log (each once); the counters keep all.
MAX_LOGGED_REFUSALS = 100
DAY = 86_400


class FleetRecordError(Exception):
    """`--record DIR` cannot be used (bad usage: the message says why)."""


def day_file(directory: Path, vessel_id: str, day: int, n: int = 1) -> Path:
    """The n-th file of `vessel_id` for UTC day number `day` (days since 1970-01-01)."""
    date = datetime.fromtimestamp(day * DAY, tz=timezone.utc).strftime("%Y-%m-%d")
    stem = f"{vessel_id}-{date}" if n == 1 else f"{vessel_id}-{date}_{n}"
    return directory / vessel_id / f"{stem}.mcap"


def _shown(name: str) -> str:
    """A name from the network as a log may show it: quoted, escaped, cut."""
    return repr(name[:80]) + ("…" if len(name) > 80 else "")


def _files_of(recorder: Any) -> int:
    """Files a recorder made: the MCAP recorder lists them (`files`); another, one."""
    files = getattr(recorder, "files", None)
    return len(files) if isinstance(files, list) else 1


def _discard(_record: Any) -> None:
    """A recorder publishes nothing."""


@dataclass
class _Vessel:
    vessel_id: str
    health: ComponentHealth
    recorder: Any = None
    day: int = 0
    last_seen: float = 0.0
    dirty: bool = False
    recent: dict[str, deque[float]] = field(default_factory=dict)


class FleetRecorder:
    """Records the samples of many vessels, one recorder and one file per vessel and day."""

    def __init__(
        self,
        directory: str | os.PathLike[str],
        *,
        registry: Registry | None = None,
        clock: Clock | None = None,
        max_vessels: int = MAX_VESSELS,
        idle_finish: float = IDLE_FINISH,
        late_grace: float = LATE_GRACE,
        recorder_type: str = RECORDER_TYPE,
        recorder_options: Mapping[str, Any] | None = None,
    ) -> None:
        self.directory = Path(directory).absolute()
        self.registry = registry or Registry()
        self.clock: Clock = clock or LiveClock()
        self.max_vessels = max_vessels
        self.idle_finish = idle_finish
        self.late_grace = late_grace
        self.recorder_type = recorder_type
        self.recorder_options = dict(recorder_options or {})
        self.health = ComponentHealth("fleet-record", "output", "fleet-record", self.clock)
        #: Counters of the vessels' recorders whose vessel is no longer recorded.
        self.retired: Counter[str] = Counter()
        self._files_closed = 0  # files of recorders closed so far
        self.vessels_started = 0
        self._vessels: dict[str, _Vessel] = {}
        self._cls: Any = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._logged_refusals: set[tuple[str, str]] = set()
        self._full_logged = False

    # -- life ----------------------------------------------------------------------------
    def open(self) -> None:
        """Make the folder and find the recorder; FleetRecordError when it cannot be."""
        d = self.directory
        if d.exists() and not d.is_dir():
            raise FleetRecordError("is not a directory")
        try:
            d.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise FleetRecordError(f"cannot be made: {exc.strerror or exc}") from None
        if not os.access(d, os.W_OK | os.X_OK):
            raise FleetRecordError("cannot create files in it (permission denied)")
        try:
            if os.statvfs(d).f_blocks == 0:
                raise FleetRecordError("is on a filesystem without storage (such as /proc or /sys)")
        except OSError:
            pass
        try:
            self._cls = self.registry.get("outputs", self.recorder_type)
        except PluginNotFound as exc:
            raise FleetRecordError(str(exc)) from None
        try:  # the options are the recorder's configuration: judged once, now
            self._config(d / "check.mcap")
        except ValueError as exc:
            raise FleetRecordError(f"recorder configuration: {exc}") from None
        self._room_for_files()
        self.health.set_state("recording")
        log.info("event=fleet-record dir=%s max_vessels=%d", d, self.max_vessels)

    def close(self) -> None:
        """Finish every vessel's file."""
        for v in list(self._vessels.values()):
            self._finish_vessel(v, "stopped")
        if self._loop is not None:
            self._loop.close()
            self._loop = None
        self.health.set_state("closed")

    # -- samples -------------------------------------------------------------------------
    def take(self, key: str, payload: bytes) -> None:
        """One sample of `vessel/<id>/est/<name>` or `vessel/<id>/health`; never raises
        on what the network sends."""
        h = self.health
        h.count("samples")
        parts = key.split("/", 2)
        if len(parts) != 3 or parts[0] != PREFIX:
            h.count("rejected.bad_key")
            return
        vid, rest = parts[1], parts[2]
        if not valid_name(vid):
            self._refuse(vid, "bad_vessel_id", "not a vessel id (letters, digits, '_', '-', '.'; at most 128)")
            return
        try:
            rec = record_from_json(rest, payload)
        except NotARecord as exc:
            h.count(f"rejected.{exc.reason}")
            h.error(f"vessel/{vid}/{rest[:80]}: rejected ({exc.reason})")
            return
        v = self._vessels.get(vid)
        if v is not None:
            recent = v.recent.get(rest)
            if recent is None:
                if len(v.recent) >= MAX_KEYS:
                    h.count("rejected.too_many_keys")
                    h.error(f"vessel/{vid}: more than {MAX_KEYS} keys: {rest[:80]!r} not recorded")
                    return
            elif rec.t in recent:
                h.count("duplicates")
                return
        day = int(rec.t // DAY)
        if v is None:
            if len(self._vessels) >= self.max_vessels:
                self._refuse(vid, "too_many_vessels",
                             f"{len(self._vessels)} vessels are being recorded, the most at once ({self.max_vessels})")
                return
            v = self._start_vessel(vid, day)
            if v is None:
                return
        elif day != v.day:
            if day > v.day or rec.t < v.day * DAY - self.late_grace:
                if not self._next_day(v, day):
                    return
            else:
                h.count("late_for_day")
        v.recent.setdefault(rest, deque(maxlen=RECENT)).append(rec.t)
        v.recorder.write([rec])
        v.dirty = True
        v.last_seen = self.clock.monotonic()
        h.count("taken")

    def flush(self) -> None:
        """Flush what the files took since the last flush; finish idle vessels' files."""
        now = self.clock.monotonic()
        for v in list(self._vessels.values()):
            if now - v.last_seen >= self.idle_finish:
                log.info("event=fleet-record-idle vessel=%s silent_s=%.0f", v.vessel_id, now - v.last_seen)
                self._finish_vessel(v, "idle")
                continue
            if v.dirty or not self._recording(v):  # a stopped recorder retries in flush
                v.dirty = False
                try:
                    v.recorder.flush()
                except Exception as exc:  # a third-party recorder's bug must not stop the fleet
                    v.health.error(f"flush: {type(exc).__name__}: {exc}")

    # -- what it did ---------------------------------------------------------------------
    def counters(self) -> Counter[str]:
        """The recorders' counters summed over every vessel, recorded now or before,
        and the samples of vessels whose recorder could not start (`dropped.open_failed`)."""
        total = Counter(self.retired)
        for v in self._vessels.values():
            total.update(v.health.counters)
        total.update({k: n for k, n in self.health.counters.items() if k.startswith("dropped.")})
        return total

    @property
    def files_made(self) -> int:
        """Files the recorders made (a recorder that could not create one made none)."""
        return self._files_closed + sum(_files_of(v.recorder) for v in self._vessels.values() if v.recorder)

    @property
    def losses(self) -> int:
        """Records taken that reached no file (dropped: a full disk, a write error, a
        recorder that could not start)."""
        return sum(n for k, n in self.counters().items() if k.startswith("dropped."))

    def _figures(self) -> list[str]:
        c = self.counters()
        own = self.health.counters
        parts = []
        for label, counts in (("refused", own), ("rejected", own), ("dropped", c)):
            d = {k.split(".", 1)[1]: n for k, n in counts.items() if k.startswith(label + ".") and n}
            if d:
                parts.append(f"{label} " + ", ".join(f"{k} {n}" for k, n in sorted(d.items())))
        return parts

    def status_line(self) -> str:
        """One line under the live table."""
        c = self.counters()
        head = (f"recording {len(self._vessels)} vessel(s) into {self.directory}: "
                f"{c.get('recorded', 0)} messages in {self.files_made} file(s)")
        return "; ".join([head, *self._figures()])

    def summary(self) -> str:
        """What the run recorded (after `close`)."""
        c = self.counters()
        head = (f"recorded {c.get('recorded', 0)} messages of {self.vessels_started} vessel(s) in "
                f"{self.files_made} file(s) under {self.directory}")
        return "; ".join([head, *self._figures()])

    # -- vessels and their files ---------------------------------------------------------
    def _refuse(self, vid: str, reason: str, why: str) -> None:
        self.health.count(f"refused.{reason}")
        if reason == "too_many_vessels" and self._full_logged:
            return
        key = (reason, vid)
        if key in self._logged_refusals:
            return
        if len(self._logged_refusals) < MAX_LOGGED_REFUSALS:
            self._logged_refusals.add(key)
            log.warning("event=fleet-record-refused vessel=%s reason=%s: %s (its samples are counted, not recorded)",
                        _shown(vid), reason, why)
        elif len(self._logged_refusals) == MAX_LOGGED_REFUSALS:
            self._logged_refusals.add(("", ""))
            log.warning("event=fleet-record-refused: further refused vessel ids are counted (refused.<reason>), "
                        "not logged")
        if reason == "too_many_vessels":
            self._full_logged = True  # once until a place frees

    def _config(self, path: Path) -> Any:
        body = {**self.recorder_options, "type": self.recorder_type, "worker": "loop", "path": str(path)}
        return self._cls.Config.model_validate(body)

    def _run(self, coro: Any) -> Any:
        if self._loop is None:
            self._loop = asyncio.new_event_loop()
        return self._loop.run_until_complete(coro)

    def _free_path(self, vid: str, day: int) -> Path | None:
        """The first file name of that vessel and day that is not taken (any entry of
        that name, a dangling link too, nor its numbered continuation)."""
        for n in range(1, MAX_FILES_PER_DAY + 1):
            p = day_file(self.directory, vid, day, n)
            if not os.path.lexists(p) and not os.path.lexists(p.with_name(f"{p.stem}.001{p.suffix}")):
                return p
        return None

    def _new_recorder(self, v: _Vessel, day: int) -> bool:
        folder = self.directory / v.vessel_id
        if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
            self.health.error(f"{folder} is not a folder of this recording")
            return False
        path = self._free_path(v.vessel_id, day)
        if path is None:
            self.health.error(f"{folder}: {MAX_FILES_PER_DAY} files of that day already")
            return False
        ctx = PluginContext(
            name=f"record.{v.vessel_id}",
            clock=self.clock,
            health=v.health,
            publish=_discard,
            vessel_id=v.vessel_id,
            config_dir=self.directory,
        )
        try:
            plugin = self._cls(self._config(path), ctx)
            plugin.check()
            self._run(plugin.open())
        except Exception as exc:  # a recorder that cannot start: this vessel's samples are lost, not the fleet
            self.health.error(f"{path}: cannot record: {type(exc).__name__}: {exc}")
            return False
        v.recorder, v.day = plugin, day
        log.info("event=fleet-record-file vessel=%s file=%s", v.vessel_id, path)
        return True

    def _start_vessel(self, vid: str, day: int) -> _Vessel | None:
        v = _Vessel(vid, ComponentHealth(f"record.{vid}", "output", self.recorder_type, self.clock))
        if not self._new_recorder(v, day):
            self._lost("open_failed")
            self.retired.update(v.health.counters)
            return None
        self._vessels[vid] = v
        self.vessels_started += 1
        return v

    def _next_day(self, v: _Vessel, day: int) -> bool:
        self._close_recorder(v)
        if self._new_recorder(v, day):
            return True
        self._lost("open_failed")
        self._retire(v)
        return False

    def _lost(self, reason: str) -> None:
        self.health.count(f"dropped.{reason}")

    def _close_recorder(self, v: _Vessel) -> None:
        rec, v.recorder = v.recorder, None
        if rec is None:
            return
        try:
            self._run(rec.close())
        except Exception as exc:
            v.health.error(f"finishing: {type(exc).__name__}: {exc}")
        self._files_closed += _files_of(rec)

    def _retire(self, v: _Vessel) -> None:
        self.retired.update(v.health.counters)
        if self._vessels.pop(v.vessel_id, None) is not None and self._full_logged:
            self._full_logged = False  # a place is free: the next refusal is news again

    def _finish_vessel(self, v: _Vessel, why: str) -> None:
        self._close_recorder(v)
        self._retire(v)
        log.info("event=fleet-record-finished vessel=%s reason=%s", v.vessel_id, why)

    @staticmethod
    def _recording(v: _Vessel) -> bool:
        try:
            return bool(v.recorder.status().get("recording", True))
        except Exception:
            return True

    def _room_for_files(self) -> None:
        """Each vessel holds a file open: raise the open-file limit to what
        `max_vessels` needs, or lower the bound to what the limit allows (said)."""
        try:
            import resource
        except ImportError:  # not a POSIX system
            return
        need = self.max_vessels + FD_RESERVE
        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
        if soft == resource.RLIM_INFINITY or soft >= need:
            return
        new = need if hard == resource.RLIM_INFINITY else min(need, hard)
        if new > soft:
            try:
                resource.setrlimit(resource.RLIMIT_NOFILE, (new, hard))
                soft = new
            except (ValueError, OSError):
                pass
        if soft < need:
            self.max_vessels = max(1, soft - FD_RESERVE)
            log.warning("event=fleet-record-limit open_files=%d: at most %d vessels recorded at once", soft,
                        self.max_vessels)
