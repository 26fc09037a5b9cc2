"""Reading a recording's messages without knowing its file format (DESIGN §4).

`edged score` and `edged plot` judge and draw what a recording holds; they live in a
plugin (`edged_analysis`) that must not import the plugin that writes the files
(`edged_mcap`): no plugin imports another. So the format plugin offers a
`RecordingReader` in the entry point group `edged.recordings` (registry role
`recordings`), and `recording_reader` picks the one for a file. What a command gets
is format-free: per message its topic, schema name, log time and decoded JSON payload,
and a `RecordingReport` of what could not be read.

This module knows no format and no sensor: it imports nothing of edged but the
registry, and nothing of any plugin.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator, NamedTuple, Protocol

from .registry import Registry

log = logging.getLogger("edged.recordings")

__all__ = [
    "HEAD_BYTES",
    "RecordedMessage",
    "RecordingError",
    "RecordingReader",
    "RecordingReport",
    "every_topic",
    "recording_reader",
]

#: What a reader's `sniff` is given: the first bytes of the file.
HEAD_BYTES = 64


class RecordedMessage(NamedTuple):
    """One message of a recording. A tuple, not a class with a dict: a recording
    holds millions, and `score` reads every one it wants."""

    topic: str
    #: The name of the message's schema (`edged.est.stw`), None when it has none.
    schema: str | None
    #: When it was logged: nanoseconds since the UNIX epoch.
    log_time: int
    #: The decoded JSON value (an object for every payload edged writes).
    payload: Any


@dataclass
class RecordingReport:
    """What reading a recording could not use; complete once the messages are exhausted."""

    #: The writer finished the file (an unfinished one is read as far as it goes).
    finished: bool = False
    #: Why reading ended before the end the writer meant, in words ("" when finished).
    unfinished_why: str = ""
    #: Damaged parts of the file skipped, each holding many messages.
    bad_chunks: int = 0
    #: Messages whose channel (topic) was lost with a damaged part: not readable.
    orphans: int = 0
    #: Messages on a wanted topic whose payload is not JSON (another encoding, damage).
    undecodable: int = 0


class RecordingError(ValueError):
    """The file is not a recording the reader can read. The message says why, without
    the file's name (the caller puts it in front, as for every other error)."""


def every_topic(topic: str) -> bool:
    """The default `wanted` of `RecordingReader.messages`: every topic."""
    return True


class RecordingReader(Protocol):
    """Reads the recordings of one file format (entry point group `edged.recordings`;
    the entry point's name is the reader's `name`)."""

    #: The format's name: the entry point's.
    name: str

    def sniff(self, head: bytes) -> bool:
        """True when a file starting with `head` (its first `HEAD_BYTES`, fewer for a
        shorter file) is of this format. Never raises."""
        ...

    def messages(
        self, path: Path, report: RecordingReport, wanted: Callable[[str], bool] = every_topic
    ) -> Iterator[RecordedMessage]:
        """The messages of the topics `wanted` says yes to, in file order; payloads are
        decoded as the standard library's `json` module decodes them (the authority on
        what is JSON), those it refuses counted in `report.undecodable` and skipped. A
        damaged or unfinished file is read as far as it can be and `report` says what
        was lost. Raises `RecordingError` for a file that is no such recording at all,
        OSError when the file cannot be read."""
        ...


def _knows(name: str, reader: RecordingReader, head: bytes) -> bool:
    try:
        return bool(reader.sniff(head))
    except Exception as exc:  # a reader's sniff must not decide for the others
        log.warning("recording reader %s: sniff failed: %s", name, exc)
        return False


def recording_reader(path: Path, registry: Registry) -> RecordingReader:
    """The reader of `path`: the first installed one (by name) whose `sniff` knows the
    file (a sniff that raises is logged and decides nothing). When none does, the only
    reader installed reads it anyway, so that its refusal says what it expected ("not a
    valid MCAP file ..."); with several, `RecordingError` names them. OSError when the
    file cannot be read."""
    with open(path, "rb") as f:
        head = f.read(HEAD_BYTES)
    readers: list[RecordingReader] = []
    for name, reader in registry.iter("recordings"):
        if _knows(name, reader, head):
            return reader
        readers.append(reader)
    if len(readers) == 1:
        return readers[0]
    names = ", ".join(registry.names("recordings")) or "none installed"
    raise RecordingError(f"not a recording any installed reader reads (readers: {names})")
