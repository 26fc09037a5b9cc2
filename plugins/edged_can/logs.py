"""The CAN input's log readers for `edged replay` (entry point group `edged.logs`).

One reader per file format: candump (its three layouts, `candump`) and each gateway
format of `formats/` whose module has `sniff` and `read`. Each reader imports its
module only when a file is sniffed or opened, so that loading the readers (the replay
driver loads them all to learn their priorities) costs no parsing or decoding stack;
the records of all of them are decoded by the `can` input's decoder.

Adding a format whose module `formats/<name>.py` has `NAME`, `sniff` and `read`:
one line here, `<NAME> = FormatReader("<name>", <priority>)`, and one entry point in
pyproject.toml, `<name> = "edged_can.logs:<NAME>"`. Priorities 20-29 (DESIGN §1):
after MCAP's magic, before NMEA 0183.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from types import ModuleType
from typing import BinaryIO, Iterator

from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import RawRecord

__all__ = ["CandumpReader", "FormatReader", "CANDUMP", "ACTISENSE_PLAIN", "YDWG_RAW", "IKONVERT"]

#: The input plugin whose decoder reads every record of these formats.
INPUT = "can"


@dataclass(frozen=True)
class FormatReader:
    """The reader of the gateway format `formats/<name>.py` (its `sniff` and `read`)."""

    name: str
    priority: int
    protocol: str = "can"
    input: str | None = INPUT

    def module(self) -> ModuleType:
        """The format's module, imported at the first sniff or open (then from
        `sys.modules`: a sniff and an open per file)."""
        return importlib.import_module(f"edged_can.formats.{self.name}")

    def sniff(self, head: bytes) -> bool:
        return bool(self.module().sniff(head))

    def open(
        self, stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
    ) -> Iterator[RawRecord]:
        return self.module().read(stream, source, health, options)


@dataclass(frozen=True)
class CandumpReader:
    """candump logs, in the three layouts `edged_can.candump` reads."""

    name: str = "candump"
    priority: int = 20
    protocol: str = "can"
    input: str | None = INPUT

    def sniff(self, head: bytes) -> bool:
        from . import candump

        return candump.sniff(head)

    def open(
        self, stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
    ) -> Iterator[RawRecord]:
        from edged.timecheck import limits_of

        from . import candump

        # Without a configuration section for this file, the bus is the interface the
        # log names, so files of one bus share one decoder (and their fast-packets).
        return candump.read(
            stream, source, health, bus_from_line=options.config is None, limits=limits_of(options)
        )


CANDUMP = CandumpReader()
ACTISENSE_PLAIN = FormatReader("actisense_plain", 21)
YDWG_RAW = FormatReader("ydwg_raw", 22)
IKONVERT = FormatReader("ikonvert", 23)
