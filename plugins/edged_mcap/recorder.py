"""The MCAP recorder output (DESIGN §7) and the MCAP reader for replay.

Recording must never stop the daemon: a full disk, a failing card or a free-space
floor stops *recording* only, with a health state saying why (`disk_low`,
`disk_full`, `failed`), and the recorder tries again later in a new file (directory
mode). `write()` never raises. Crash safety comes from small chunks and a flush (and
fsync) about every second, driven by the runtime's `flush()`.
"""

from __future__ import annotations

import errno
from pathlib import Path
from typing import Any, BinaryIO, Callable, ClassVar, Iterator

import edged
from edged.health import ComponentHealth
from edged.plugin import OutputPlugin, PluginContext, ReplayOptions
from edged.records import RawRecord

from . import files
from .channels import dumps, encode, to_ns
from .config import GIB, McapConfig
from .mcapfile import McapFile
from .reading import MAGIC
from .replay import read_raw

__all__ = ["McapRecorder", "Opener"]

#: Opens a recording file: (path, mode) -> binary stream. Injectable for tests.
Opener = Callable[[Path, str], BinaryIO]

#: Health states of the recorder beyond the runtime's own.
RECORDING = "recording"
DISK_LOW = "disk_low"  # free space below the floor: stopped on purpose, resumes by itself
DISK_FULL = "disk_full"  # a write failed for lack of space
FAILED = "failed"  # any other write or open error

#: Log times are uint64 nanoseconds: data time must lie in [1970, 2554).
MAX_T = (2**64 - 1) / 1e9


def _default_opener(path: Path, mode: str) -> BinaryIO:
    return open(path, mode)  # noqa: SIM115 - McapFile owns and closes it


def _write_error_state(exc: OSError) -> str:
    return DISK_FULL if exc.errno in (errno.ENOSPC, errno.EDQUOT) else FAILED


class McapRecorder(OutputPlugin):
    """Records everything the router carries into MCAP files."""

    Config: ClassVar[type[McapConfig]] = McapConfig
    description: ClassVar[str] = "MCAP recorder: raw data, measurements, estimates, health"

    def __init__(
        self,
        config: McapConfig,
        ctx: PluginContext,
        *,
        free_bytes: files.FreeBytes = files.disk_free,
        opener: Opener = _default_opener,
    ) -> None:
        super().__init__(config, ctx)
        self.config: McapConfig = config
        self._free_bytes = free_bytes
        self._opener = opener
        self._file: McapFile | None = None
        self._started = 0.0  # clock.monotonic() when the current file began
        self._next_check = 0.0  # next free-space check / resume attempt (monotonic)
        self._stopped = "not_open"  # why nothing is being recorded (when _file is None)
        self._final = False  # an exact file that failed is never reopened
        self.files: list[Path] = []

    # -- the OutputPlugin contract -----------------------------------------------------
    async def open(self) -> None:
        self._final = False
        self._start_file()

    def write(self, batch: list[Any]) -> None:
        """Record `batch`; every record of a replay passes here, so the loop keeps to
        plain local names (the file's channel table, its message adder) and converts a
        time to nanoseconds once for the run of records that share it (the sentences
        of one GNSS epoch, a raw record and its measurements)."""
        f = self._file
        health = self.ctx.health
        if f is None:
            health.count(f"dropped.{self._stopped}", len(batch))
            return
        pub = to_ns(self.ctx.clock.now())
        channels = f.channels
        add = f.add_message
        last_t: Any = None
        log = 0
        n = 0
        for i, rec in enumerate(batch):
            try:
                outs = encode(rec)
            except KeyError:
                health.count("rejected.unknown_record")
                health.error(f"not a record edged knows: {type(rec).__name__}")
                continue
            except (AttributeError, TypeError, ValueError) as exc:  # e.g. raw data that is not bytes
                health.count("rejected.malformed")
                health.error(f"malformed {type(rec).__name__}: {type(exc).__name__}: {exc}")
                continue
            t = getattr(rec, "t", None)
            if t != last_t or t.__class__ is not last_t.__class__:
                if not isinstance(t, (int, float)) or not 0.0 <= t < MAX_T:
                    health.count("rejected.bad_time")
                    health.error(f"record time outside the MCAP range: {t!r} ({type(rec).__name__})")
                    continue
                log = to_ns(t)
                last_t = t
            try:
                for topic, schema, payload in outs:
                    try:
                        data, cleaned = dumps(payload)
                    except (TypeError, ValueError) as exc:
                        health.count("rejected.unencodable")
                        health.error(f"{topic}: not JSON: {exc}")
                        continue
                    if cleaned:
                        health.count("nonfinite_as_null")
                    cid = channels.get(topic)
                    if cid is None:
                        cid = f.channel(topic, schema)
                    add(cid, log, data, pub)
                    n += 1
            except OSError as exc:
                health.count("recorded", n)
                self._fail(exc)
                health.count(f"dropped.{self._stopped}", len(batch) - i)
                return
        health.count("recorded", n)
        self._maybe_rotate()

    def flush(self) -> None:
        now = self.ctx.clock.monotonic()
        f = self._file
        if f is None:
            if not self._final and now >= self._next_check:
                self._start_file()
            return
        try:
            f.flush(self.config.fsync)
        except OSError as exc:
            self._fail(exc)
            return
        if now >= self._next_check:
            self._next_check = now + self.config.retry_seconds
            if not self._enough_space(f.path.parent):
                self._finish(DISK_LOW)
                return
        self._maybe_rotate()

    def rotate(self) -> None:
        """SIGHUP: a new file now (directory mode); also an immediate resume attempt."""
        if self.config.directory is None:
            self.ctx.log.info("event=rotate-ignored reason='recording one exact file (path)'")
            return
        if self._file is not None:
            self._rotate_now("signal")
        elif not self._final:
            self._start_file()

    async def close(self) -> None:
        if self._file is not None:
            self._finish("closed")
        self.ctx.health.set_state("closed")

    def status(self) -> dict[str, Any]:
        f = self._file
        return {
            "file": str(f.path) if f else None,
            "files": len(self.files),
            "recording": f is not None,
            **({} if f else {"stopped": self._stopped}),
        }

    # -- replay: reading recordings back ----------------------------------------------
    @classmethod
    def sniff(cls, head: bytes) -> bool:
        return head.startswith(MAGIC)

    @classmethod
    def open_replay(
        cls, stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
    ) -> Iterator[RawRecord]:
        """The recorded raw channels as RawRecords, exactly as they were recorded."""
        return read_raw(stream, health, options.path or source)

    # -- files ---------------------------------------------------------------------------
    def _target(self) -> Path:
        cfg = self.config
        if cfg.path is not None:
            return cfg.path
        assert cfg.directory is not None
        return files.new_file(cfg.directory, self.ctx.clock.now())

    def _enough_space(self, folder: Path) -> bool:
        floor = int(self.config.min_free_gib * GIB)
        try:
            free = self._free_bytes(folder)
        except OSError as exc:
            self.ctx.health.error(f"free space of {folder}: {exc.strerror or exc}")
            return True  # unknown is not low: keep recording, the write itself will tell
        self.ctx.health.info["disk_free_bytes"] = free
        if free < floor:
            self.ctx.health.error(
                f"free disk {free / GIB:.2f} GiB below the floor {self.config.min_free_gib} GiB: recording stopped"
            )
            return False
        return True

    def _start_file(self) -> None:
        cfg = self.config
        health = self.ctx.health
        now = self.ctx.clock.monotonic()
        self._next_check = now + cfg.retry_seconds
        folder = cfg.directory if cfg.directory is not None else cfg.path.parent  # type: ignore[union-attr]
        try:
            folder.mkdir(parents=True, exist_ok=True)
            if not self._enough_space(folder):
                self._stop(DISK_LOW)
                return
            path = self._target()
            stream = self._opener(path, "wb" if cfg.path is not None else "xb")
        except OSError as exc:
            self._stop(_write_error_state(exc), f"cannot open a recording in {folder}: {exc.strerror or exc}")
            return
        try:
            self._file = McapFile(
                stream,
                path,
                compression=cfg.compression,
                chunk_size=cfg.chunk_kib * 1024,
                library=f"edged {edged.__version__}",
                metadata=self._metadata(),
            )
        except OSError as exc:
            try:
                stream.close()
            except OSError:
                pass
            self._stop(_write_error_state(exc), f"{path}: {exc.strerror or exc}")
            return
        self._started = now
        self.files.append(path)
        health.info["file"] = str(path)
        health.count("files")
        health.set_state(RECORDING)
        self.ctx.log.info("event=recording file=%s", path)
        self._prune(path)

    def _metadata(self) -> dict[str, str]:
        return {
            "vessel_id": self.ctx.vessel_id,
            "edged_version": edged.__version__,
            "config": str(self.ctx.options.get("config_text") or ""),
            "started": files.stamp(self.ctx.clock.now()),
        }

    def _prune(self, current: Path) -> None:
        cfg = self.config
        if cfg.directory is None or (cfg.keep_files is None and cfg.keep_gib is None):
            return
        keep_bytes = int(cfg.keep_gib * GIB) if cfg.keep_gib is not None else None
        try:
            deleted = files.prune(cfg.directory, cfg.keep_files, keep_bytes, current)
        except OSError as exc:
            self.ctx.health.error(f"retention: {exc.strerror or exc}")
            return
        if deleted:
            self.ctx.health.count("files_deleted", len(deleted))
            self.ctx.log.info("event=retention deleted=%s", ",".join(p.name for p in deleted))

    def _maybe_rotate(self) -> None:
        cfg = self.config
        f = self._file
        if f is None or cfg.directory is None:
            return
        if cfg.rotate_seconds is not None and self.ctx.clock.monotonic() - self._started >= cfg.rotate_seconds:
            self._rotate_now("duration")
            return
        try:
            size = f.size
        except OSError as exc:
            self._fail(exc)
            return
        if cfg.rotate_bytes is not None and size >= cfg.rotate_bytes:
            self._rotate_now("size")

    def _rotate_now(self, why: str) -> None:
        self.ctx.health.count(f"rotations.{why}")
        if self._finish(None):
            self._start_file()

    def _finish(self, stop_reason: str | None) -> bool:
        """Finish the current file cleanly; False when that failed (already handled)."""
        f = self._file
        self._file = None
        if f is None:
            return False
        try:
            f.finish()
        except OSError as exc:
            self._stop(_write_error_state(exc), f"{f.path}: finishing: {exc.strerror or exc}")
            return False
        if stop_reason is not None:
            self._stop(stop_reason)
        return True

    def _fail(self, exc: OSError) -> None:
        """A write error: abandon the file as it is (recoverable) and stop recording."""
        f = self._file
        self._file = None
        if f is not None:
            f.abandon()
        where = f.path if f is not None else "recording"
        self._stop(_write_error_state(exc), f"{where}: write failed: {exc.strerror or exc}")

    def _stop(self, state: str, message: str | None = None) -> None:
        health = self.ctx.health
        self._stopped = state
        health.info["file"] = None
        if message:
            health.error(message)
        if self.config.path is not None and self.files:
            # Reopening an exact file would truncate what it already holds.
            self._final = True
        if state != "closed":
            health.count(f"stops.{state}")
            when = "not retried: exact file" if self._final else f"retried every {self.config.retry_seconds:g} s"
            self.ctx.log.warning("event=recording-stopped state=%s %s", state, when)
        health.set_state(state, message)
