"""The MCAP recorder output (DESIGN §7); its files are read back for replay by
`logs.MCAP` (entry point group `edged.logs`).

Recording must never stop the daemon: a full disk, a failing card or a free-space
floor stops *recording* only, with a health state saying why (`disk_low`,
`disk_full`, `failed`), and the recorder tries again later in a new file (directory
mode). `write()` never raises. Crash safety comes from small chunks and a flush (and
fsync) about every second, driven by the runtime's `flush()`.

What health says (beside the runtime's `written`, the records handed to this output):

- `recorded`: messages that reached the file, counted when the chunk holding them has
  been flushed to the file (at each flush, at a rotation and at the close), so that a
  message lost in a chunk a write error never let out is not counted;
- `dropped.<state>`: messages not recorded because recording was stopped (`disk_low`,
  `disk_full`, `failed`, `closed`, `not_open`) or lost in the chunk open when a write
  failed; `rejected.<reason>`: records that cannot be recorded (`bad_time`,
  `unknown_record`, `malformed`, `unencodable`);
- `info.disk_free_bytes`: free space of the recording folder, measured at every flush
  and at every attempt to (re)start.

A disk without room leaves no file behind: the free space is checked before a file is
created (at least the floor and room for a chunk), the header is written out at once,
and a file that got no complete chunk (nothing but its header, perhaps the start of a
chunk the full disk cut short) when a write failed is removed, counted
`files_removed_empty` (a file with data stays, for `edged recover`). Retries after a
failed attempt back off, from `retry_seconds` doubling up to `RETRY_MAX_SECONDS`; a
stop by the free-space floor alone is checked every `retry_seconds` (it creates
nothing). A state is logged once when it is entered, not at every retry.

Memory stays flat however long the recording: the `mcap` Writer keeps one chunk index
entry per chunk in memory until the file is finished (packed to about 200 bytes by
`fastmessages.PackedChunkIndexes`, 1.4 KB as the library's objects), so a file is
finished and the next one begun when it reaches `max_chunks` chunks (`MAX_CHUNKS`;
counted `rotations.index`). In directory mode that is one more rotated file; with an
exact `path` (`edged replay --record OUT.mcap`) the first file keeps the exact name and
the next ones are numbered beside it: `OUT.mcap`, `OUT.001.mcap`, `OUT.002.mcap`, ...
(at the reference load, one file per about three hours of data); `files` lists them.
An exact recording that stopped on an error after it recorded data is not resumed, in
that file or a numbered one; one that got nothing (removed) is retried.
"""

from __future__ import annotations

import errno
from pathlib import Path
from typing import Any, BinaryIO, Callable, ClassVar

import edged
from edged.backoff import Backoff
from edged.plugin import OutputPlugin, PluginContext

from . import files
from .batches import DERIVED, WriteFailed, record_batch
from edged.channels import to_ns
from .config import McapConfig
from .mcapfile import McapFile
from .placement import Placement
from .reading import messages_after

__all__ = ["McapRecorder", "Opener"]

#: Opens a recording file: (path, mode) -> binary stream. Injectable for tests.
Opener = Callable[[Path, str], BinaryIO]

#: Health states of the recorder beyond the runtime's own.
RECORDING = "recording"
DISK_LOW = "disk_low"  # free space below the floor: stopped on purpose, resumes by itself
DISK_FULL = "disk_full"  # a write failed for lack of space
FAILED = "failed"  # any other write or open error

#: The longest wait between two attempts to resume after failed ones (seconds).
RETRY_MAX_SECONDS = 300.0
#: Chunks per file before the next file: bounds the Writer's in-memory chunk index
#: (about 200 bytes a chunk, packed: 8 MB; at the reference load about 3.4 chunks per
#: second of data, so a file holds about three hours).
MAX_CHUNKS = 40_000


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
        max_chunks: int = MAX_CHUNKS,
    ) -> None:
        super().__init__(config, ctx)
        self.config: McapConfig = config
        self._place = Placement(config, ctx, free_bytes)
        self._opener = opener
        self._file: McapFile | None = None
        self._started = 0.0  # clock.monotonic() when the current file began
        self._next_check = 0.0  # next free-space check / resume attempt (monotonic)
        self._stopped = "not_open"  # why nothing is being recorded (when _file is None)
        self._final = False  # an exact file that failed is never reopened
        self._max_chunks = max_chunks
        self._pending = 0  # messages added to the open chunk(s), not yet flushed to the file
        #: The ledger (records, not messages) a parent reads when this process is killed:
        #: records whose fate is settled (in a flushed or finished file, rejected,
        #: dropped and counted), records added to the current file since its last
        #: flush, and where that flush ended in the file.
        self._settled = 0
        self._unflushed = 0
        self._flushed_bytes = 0
        #: The wait after each attempt in a row that failed with an OS error.
        self._backoff = Backoff(config.retry_seconds, max(RETRY_MAX_SECONDS, config.retry_seconds))
        self.files: list[Path] = []

    # -- the OutputPlugin contract -----------------------------------------------------
    async def open(self) -> None:
        self._final = False
        self._start_file()

    def write(self, batch: list[Any]) -> None:
        """Record `batch` (`batches.record_batch`); what a failed write lost is counted
        dropped. Never raises."""
        f = self._file
        if f is None:
            self.ctx.health.count(f"dropped.{self._stopped}", len(batch))
            self._settled += len(batch)
            return
        try:
            done = record_batch(f, batch, to_ns(self.ctx.clock.now()), self.ctx.health)
        except WriteFailed as failed:
            self._settled += failed.rejected  # (the ledger: the rejected are settled at once)
            self._pending += failed.added
            self._fail(failed.error)
            self.ctx.health.count(f"dropped.{self._stopped}", len(batch) - failed.first_lost)
            self._settled += len(batch) - failed.rejected  # dropped, or in the file left behind
            return
        self._settled += done.rejected
        self._pending += done.added
        self._unflushed += len(batch) - done.rejected
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
            flushed = f.size
        except OSError as exc:
            self._fail(exc)
            return
        self._confirm()
        self._flushed_bytes = flushed
        if not self._place.enough_space(f.path.parent):
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

    def _confirm(self) -> None:
        """What was added so far is in the file now: count it recorded."""
        self._settled += self._unflushed
        self._unflushed = 0
        if self._pending:
            self.ctx.health.count("recorded", self._pending)
            self._pending = 0
            self._backoff.reset()  # a file that took data: the next trouble starts afresh

    def _lose_pending(self) -> None:
        self._settled += self._unflushed
        self._unflushed = 0
        if self._pending:
            self.ctx.health.count(f"dropped.{self._stopped}", self._pending)
            self._pending = 0

    # -- a process of its own that is killed (see OutputPlugin.ledger) -------------------
    def ledger(self) -> dict[str, Any]:
        """Records settled so far, and the current file with where its last flush ended
        and the channels of derived messages (a record's second message, not counted)."""
        f = self._file
        return {
            "settled": self._settled,
            "file": None if f is None else str(f.path),
            "flushed_bytes": self._flushed_bytes,
            "derived": [] if f is None else sorted(cid for t, cid in f.channels.items() if t.startswith(DERIVED)),
        }

    def lost_at_death(self, handed: int, ledger: dict[str, Any] | None) -> int | None:
        """The records handed to a killed recorder that are in no file: those it had not
        settled, less those its file holds past its last flush (chunks it wrote
        between two flushes, and after its last answer)."""
        if ledger is None:
            return None
        unknown = handed - int(ledger["settled"])
        path = ledger.get("file")
        if path and unknown > 0:
            unknown -= messages_after(path, int(ledger["flushed_bytes"]), set(ledger["derived"]), DERIVED)
        return max(0, unknown)

    def status(self) -> dict[str, Any]:
        f = self._file
        return {
            "file": str(f.path) if f else None,
            "files": len(self.files),
            "recording": f is not None,
            **({} if f else {"stopped": self._stopped}),
        }

    # -- files ---------------------------------------------------------------------------
    def _start_file(self) -> None:
        """Begin a new file when the folder has room for it; else stop, saying why."""
        now = self.ctx.clock.monotonic()
        self._next_check = now + self.config.retry_seconds
        place = self._place
        folder = place.folder
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            self._failed_attempt(_write_error_state(exc), f"cannot open a recording in {folder}: {exc.strerror or exc}")
            return
        free = place.measure_free(folder)
        if not place.enough_space(folder, free):
            self._stop(DISK_LOW)
            return
        need = place.room_needed()
        if free is not None and free < need:
            # Not even room for a chunk: creating the file would leave an empty one.
            self._stop(DISK_FULL, f"cannot open a recording in {folder}: less than {need} bytes free")
            return
        try:
            f = self._new_file(place.target(len(self.files)))
        except OSError as exc:
            self._failed_attempt(_write_error_state(exc), f"cannot open a recording in {folder}: {exc.strerror or exc}")
            return
        self._file = f
        self._flushed_bytes = f.header_size
        self._started = now
        self.files.append(f.path)
        health = self.ctx.health
        health.info["file"] = str(f.path)
        health.count("files")
        health.set_state(RECORDING)
        self.ctx.log.info("event=recording file=%s", f.path)
        place.prune(f.path)

    def _new_file(self, path: Path) -> McapFile:
        """The file at `path`, created and begun (its header written out at once); one
        that failed to begin is removed (counted `files_removed_empty`) before OSError
        is passed on."""
        cfg = self.config
        stream = self._opener(path, "wb" if cfg.path is not None else "xb")
        f = McapFile(
            stream,
            path,
            compression=cfg.compression,
            chunk_size=cfg.chunk_kib * 1024,
            library=f"edged {edged.__version__}",
            metadata=self._place.metadata(),
        )
        try:
            f.start()
        except OSError:
            f.abandon()
            if f.remove_if_empty(header_only=False):
                self.ctx.health.count("files_removed_empty")
            raise
        return f

    def _maybe_rotate(self) -> None:
        cfg = self.config
        f = self._file
        if f is None:
            return
        if f.index_entries >= self._max_chunks:
            self._rotate_now("index")
            return
        if cfg.directory is None:
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
            state = _write_error_state(exc)
            self._stopped = state
            self._lose_pending()
            if f.remove_if_empty():
                self._forget(f.path)
            self._failed_attempt(state, f"{f.path}: finishing: {exc.strerror or exc}")
            return False
        self._confirm()
        if stop_reason is not None:
            self._stop(stop_reason)
        return True

    def _fail(self, exc: OSError) -> None:
        """A write error: abandon the file as it is (recoverable) and stop recording."""
        f = self._file
        self._file = None
        state = _write_error_state(exc)
        self._stopped = state
        self._lose_pending()
        where = f.path if f is not None else "recording"
        if f is not None:
            f.abandon()
            if f.remove_if_empty():
                # Nothing but its header: no reader accepts it and nothing is lost.
                self._forget(f.path)
                self.ctx.log.info("event=recording-removed file=%s reason='held only its header'", f.path)
        self._failed_attempt(state, f"{where}: write failed: {exc.strerror or exc}")

    def _forget(self, path: Path) -> None:
        if self.files and self.files[-1] == path:
            self.files.pop()
        self.ctx.health.count("files_removed_empty")

    def _failed_attempt(self, state: str, message: str) -> None:
        """Stop after an OS error, and wait longer before each new attempt in a row."""
        self._next_check = self.ctx.clock.monotonic() + self._backoff.next_delay()
        self._stop(state, message)

    def _stop(self, state: str, message: str | None = None) -> None:
        health = self.ctx.health
        self._stopped = state
        health.info["file"] = None
        if message:
            health.error(message)
        if self.config.path is not None and self.files:
            # Reopening an exact file would truncate what it already holds.
            self._final = True
        if state != "closed" and health.state != state:  # once per change of state
            health.count(f"stops.{state}")
            if self._final:
                when = "not retried: exact file"
            else:
                when = f"retried in {max(0.0, self._next_check - self.ctx.clock.monotonic()):g} s"
            self.ctx.log.warning("event=recording-stopped state=%s %s", state, when)
        health.set_state(state, message)
