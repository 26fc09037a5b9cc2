"""The plugin contract: every input, estimator and output is one of these.

Shaped after Signal K's plugin contract: a plugin has a type name (its entry point),
a configuration schema (a pydantic model; unknown keys are errors), a lifecycle the
runtime supervises, and health it reports. Three roles:

- `InputPlugin`: owns a transport and a decoder; emits raw records and measurements.
  Its class also says how to decode raw records again (`make_decoder`), so that
  replay uses the very decoders the live input uses.
- `EstimatorPlugin`: names a synchronous core class (`edged.estimator.Estimator`:
  `step(record) -> [Estimate]`, `tick`, `health`) and makes one; the runtime hosts it
  in a worker with its own queue.
- `OutputPlugin`: receives batches of records (raw, measurements, estimates, health).

Beside the three roles, a `LogReader` reads the files of one log format for
`edged replay` (`sniff`, `open`): one reader per format, whatever plugin it belongs to,
so that the replay driver asks the readers and no input or output class.

Plugins are discovered through the entry point groups `edged.inputs`,
`edged.estimators` and `edged.outputs`; log readers in `edged.logs`; the estimate
kinds an estimator package declares in `edged.estimate_kinds` (`edged.estimates`);
recording readers in `edged.recordings` (`edged.recordings`); subcommands in
`edged.commands` (`edged.subcommand.Subcommand`).
"""

from __future__ import annotations

import ipaddress
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import (Any, BinaryIO, Callable, ClassVar, Iterable, Iterator, Literal, Mapping, NamedTuple, Protocol,
                    runtime_checkable)

from pydantic import BaseModel, ConfigDict, Field

from .clock import Clock
from .estimator import Estimator
from .health import ComponentHealth
from .records import Measurement, RawRecord

__all__ = [
    "Claim",
    "ANY_ADDRESS",
    "address_key",
    "listen_claim",
    "serial_claim",
    "PluginConfig",
    "InputConfig",
    "EstimatorConfig",
    "OutputConfig",
    "PluginContext",
    "Plugin",
    "Decoder",
    "InputPlugin",
    "EstimatorPlugin",
    "OutputPlugin",
    "ReplayOptions",
    "LogReader",
]


class Claim(NamedTuple):
    """A resource a plugin instance holds for itself while it runs (`PluginConfig.claims`).

    Two enabled plugins whose claims have resources of the same length, equal in every
    place (a `"*"` matches anything in its place: a wildcard address), cannot both run;
    the configuration is refused naming both keys.
    """

    #: The key of the plugin's table that names the resource: "port", "device", "listen".
    key: str
    #: What is held, e.g. ("udp", "127.0.0.1", "10110") or ("serial", "/dev/ttyUSB0").
    resource: tuple[str, ...]
    #: The message's words for it: "listen on udp 127.0.0.1:10110".
    text: str


#: Addresses that mean every address of a port (a wildcard listen).
ANY_ADDRESS = frozenset({"", "0.0.0.0", "::", "[::]", "*"})


def address_key(host: str) -> str:
    """A listen address as claims compare it: `*` for a wildcard, an IP address in its
    compressed form, a name in lower case."""
    if host in ANY_ADDRESS:
        return "*"
    h = host.strip("[]")
    try:
        return ipaddress.ip_address(h).compressed
    except ValueError:
        return h.lower()


def listen_claim(key: str, proto: str, host: str, port: int | str, text: str | None = None) -> Claim:
    """The claim of a port listened on (`proto` "udp" or "tcp"), the same for every
    plugin, so that an input, an output and a zenoh endpoint on one port collide."""
    shown = f"[{host}]" if ":" in host and not host.startswith("[") else host
    return Claim(key, (proto, address_key(host), str(port)), text or f"listen on {proto} {shown}:{port}")


def serial_claim(device: str, key: str = "device", text: str | None = None) -> list[Claim]:
    """The claim of a serial device (its real path: two names of one tty collide);
    none for a pyserial URL (socket://, rfc2217://), which holds no device of its own."""
    if "://" in device:
        return []
    return [Claim(key, ("serial", os.path.realpath(device)), text or f"use serial {device}")]


class PluginConfig(BaseModel):
    """Base of every plugin's configuration section. Unknown keys are errors, and so are
    `inf` and `nan` in any number (a plugin bounds each of its numbers as well)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    type: str
    #: false: the table is checked but the plugin is not started.
    enabled: bool = True

    def claims(self) -> list[Claim]:
        """The resources this instance holds exclusively (a UDP port it listens on, a
        serial device it reads); none by default. The core knows no transport: it only
        compares the claims of all enabled plugins and refuses two that collide.

        Cooperative: a configuration mixin placed after this class in the bases (the
        zenoh session settings) may define `claims` too, and is asked here."""
        nxt = getattr(super(), "claims", None)
        return list(nxt()) if nxt is not None else []


class InputConfig(PluginConfig):
    pass


class EstimatorConfig(PluginConfig):
    """What every estimator instance can be told, whatever its filter (DESIGN §2, §6)."""

    #: Records queued for the worker before new ones are dropped (counted `overflow`).
    queue_size: int = Field(10_000, ge=1, le=10_000_000)
    #: Measurements up to this many seconds older than the newest are re-ordered
    #: before the core sees them; older ones are late (counted, dropped).
    reorder_window: float = Field(0.0, ge=0.0, le=3600.0)
    #: Only measurements from these sources (default: all, with source priority).
    sources: list[str] | None = None
    #: See only the source priority's winner of a kind (false: every source of it, for
    #: an estimator that fuses two receivers of the same kind).
    preferred_only: bool = True
    #: Where the core runs: in the event loop, or in a process of its own (a heavy
    #: filter then never takes the loop from the inputs).
    worker: Literal["loop", "process"] = "loop"
    #: Publish at most this many estimates per second of data time (the newest since
    #: the previous tick of the grid k/publish_rate); 0 publishes every estimate.
    publish_rate: float = Field(0.0, ge=0.0, le=1000.0)
    #: Seconds of data time without any input after which the estimate is published
    #: again with `stale: true` (and its `age`) at every tick; 0 never marks it stale.
    stale_after: float = Field(5.0, ge=0.0, le=86_400.0)
    #: Process worker: seconds a batch may take before the core is declared hung,
    #: killed and restarted.
    watchdog: float = Field(10.0, gt=0.0, le=3600.0)


class OutputConfig(PluginConfig):
    #: Records queued for the output before new ones are dropped (counted `overflow`).
    queue_size: int = Field(100_000, ge=1, le=10_000_000)
    #: Where the output runs: in the event loop, or in a process of its own
    #: (`edged.outputproc`: its work then uses another core, and a slow disk or peer
    #: stalls only it). The plugin and its configuration must then be picklable.
    worker: Literal["loop", "process"] = "loop"
    #: Output in a process: seconds a call (a batch written, a flush, opening, closing)
    #: may take before the process is declared hung, killed and restarted (what it
    #: had is counted `dropped.process_died`). Generous: a slow disk's fsync is not a
    #: hang; `ready` is bound by its own timeout instead.
    watchdog: float = Field(60.0, gt=0.0, le=3600.0)


#: What edged's own outputs' traffic carries, by mark (see `OutputPlugin.own_marks`).
OwnMarks = Mapping[str, frozenset[str]]
NO_MARKS: OwnMarks = MappingProxyType({})


def own_marks_of(outputs: Iterable[tuple[type, Any]]) -> OwnMarks:
    """The union of the marks of the outputs (class, configuration) configured."""
    marks: dict[str, frozenset[str]] = {}
    for cls, config in outputs:
        for k, v in cls.own_marks(config).items():
            marks[k] = marks.get(k, frozenset()) | frozenset(v)
    return MappingProxyType(marks)


@dataclass
class PluginContext:
    """What the runtime gives a plugin instance: its name, time, health, the router."""

    name: str
    clock: Clock
    health: ComponentHealth
    publish: Callable[[Any], None]
    vessel_id: str = "vessel"
    config_dir: Path = field(default_factory=Path.cwd)
    #: Options of the whole daemon a plugin may read (e.g. `zenoh_config`, `record_dir`).
    options: dict[str, Any] = field(default_factory=dict)
    #: Set for inputs: the decoder the runtime made with `make_decoder`.
    decoder: "Decoder | None" = None

    @property
    def log(self) -> logging.Logger:
        return logging.getLogger(f"edged.{self.name}")

    def ingest(self, raw: RawRecord) -> None:
        """Publish a raw record and every measurement its decoder makes of it."""
        self.publish(raw)
        dec = self.decoder
        if dec is not None:
            for m in dec.decode(raw):
                self.publish(m)


class Plugin:
    """Base of all plugins. Subclasses set `Config` and implement `run`."""

    #: The configuration schema of this plugin's section.
    Config: ClassVar[type[PluginConfig]] = PluginConfig
    #: Human description for `--help`-like listings.
    description: ClassVar[str] = ""

    def __init__(self, config: Any, ctx: PluginContext) -> None:
        self.config = config
        self.ctx = ctx

    def check(self) -> None:
        """Raise ValueError when this plugin cannot work as configured.

        Called once before anything starts, for what the schema alone cannot judge:
        files the configuration or the command line names, their contents. The message
        becomes a configuration error (exit code 2) naming the plugin's table.
        """

    def status(self) -> dict[str, Any]:
        """Extra plugin-specific status merged into health `info`."""
        return {}


@runtime_checkable
class Decoder(Protocol):
    """Turns raw records of one protocol and source into measurements.

    Stateful (fast-packet reassembly, variation from an earlier sentence) but never
    reads the clock: time comes from `raw.t`. Rejections are counted in the health it
    was made with; it never raises on bad input.
    """

    def decode(self, raw: RawRecord) -> list[Measurement]: ...


@dataclass
class ReplayOptions:
    """Options of `edged replay` an input's file reader may need."""

    date: str | None = None  # YYYY-MM-DD for NMEA logs without a date
    config: Any = None  # the input's configuration section when one is given
    path: Path | None = None  # the file being read, for messages
    #: The plausible-time window (`edged.timecheck.TimeLimits`); None: its defaults.
    time_limits: Any = None


class InputPlugin(Plugin):
    Config: ClassVar[type[PluginConfig]] = InputConfig
    #: Decoder family of the raw records this input makes, e.g. "nmea0183", "can".
    protocol: ClassVar[str] = ""

    async def run(self) -> None:
        """Read the transport until cancelled; raising makes the runtime restart it."""
        raise NotImplementedError

    @classmethod
    def make_decoder(cls, source: str, config: Any, health: ComponentHealth, own: OwnMarks = NO_MARKS) -> Decoder:
        """The decoder of this input's raw records. `own` is what edged's own outputs'
        traffic carries (`OutputPlugin.own_marks`): a record that bears one of the
        marks the decoder knows is counted `rejected.own_output`, never decoded, so
        that an output looped into an input (a shared UDP port, a bus) makes no
        measurement of edged's own estimates."""
        raise NotImplementedError



@runtime_checkable
class LogReader(Protocol):
    """Reads the files of one log format for `edged replay` (entry point group
    `edged.logs`; the entry point's name is the reader's `name`).

    The driver loads every installed reader to learn its `priority`, so the module
    that holds a reader must be light: `sniff` needs a few regular expressions, and
    the reading and decoding stack (numpy, cantools, the mcap library) is imported
    by `open` and by the input's decoder, only for a file of this format.
    """

    #: The format's name: the entry point's, shown in "format not recognised".
    name: str
    #: The protocol of the raw records it yields ("can", "nmea0183"); "" when a file
    #: carries many (an MCAP recording): each record's own protocol then says.
    protocol: str
    #: The type name of the input plugin whose `make_decoder` decodes its records
    #: ("can"), so that a replay loads that one input and not all; None when the
    #: records say themselves (MCAP). It is also the type of the file's health
    #: component (the reader's `name` when None).
    input: str | None
    #: Sniff order, lower first, ties by name: a binary magic (MCAP 10) before the
    #: CAN and gateway text formats (20-29), NMEA 0183 last (90), so that a file of
    #: `$PCDIN`/`$MXPGN` sentences stays NMEA 0183's.
    priority: int

    def sniff(self, head: bytes) -> bool:
        """True when a file starting with `head` (up to `edged.logformats.HEAD_BYTES`) is
        of this format. Never raises on any bytes (one that does is logged and
        skipped: it does not decide for the other readers)."""
        ...

    def open(
        self, stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
    ) -> Iterator[RawRecord]:
        """Raw records of a log file in file order, stamped with the log's time.

        `stream` is the file opened in binary mode (the runtime counts the bytes read
        for its progress bar); `source` is the input name (the file's stem unless the
        configuration names it). Lines or frames that cannot be read are counted in
        `health` under `rejected.<reason>` and skipped; the iterator never raises on
        bad content. Records may carry other sources than `source` (an MCAP file holds
        many); each is decoded by the decoder of its own `protocol` and `source`.
        """
        ...


class EstimatorPlugin(Plugin):
    """An estimator: its configuration, the core class it runs and the estimate kind
    it publishes. The worker host (`edged.workers`) hosts its core."""

    Config: ClassVar[type[PluginConfig]] = EstimatorConfig
    #: The estimate kind its estimates are (`edged.estimates.ESTIMATE_KINDS`, filled
    #: from the entry point group `edged.estimate_kinds`), which says their fields;
    #: None for a kind no installed package defines.
    kind: ClassVar[str | None] = None
    #: The core's class: what it consumes and whether it ticks are read from it and
    #: the configuration, without making a core.
    Core: ClassVar[type[Estimator] | None] = None

    def core_class(self) -> type[Estimator]:
        """The core's class under this configuration: `Core`. A plugin whose
        configuration chooses between core classes (one with its own `tick`, one
        without) overrides this; `inputs`, `ticks` and `make_core` ask it."""
        if self.Core is None:
            raise TypeError(f"{type(self).__name__} names no Core (an edged.estimator.Estimator subclass)")
        return self.Core

    def inputs(self) -> frozenset[str]:
        """The route keys its core consumes under this configuration (measurement
        kinds, `est/<name>` of the instances it reads)."""
        return self.core_class().consumes(self.config)

    def ticks(self) -> bool:
        """Whether its core computes estimates at the ticks (`Estimator.tick`)."""
        return self.core_class().ticks

    def make_core(self) -> Estimator:
        """A fresh core; called at start and after every failure (in the worker's
        process when it runs in one: the core need not be picklable, the plugin's
        class and configuration must be)."""
        return self.core_class()(self.config)


class OutputPlugin(Plugin):
    Config: ClassVar[type[PluginConfig]] = OutputConfig
    #: Route keys this output wants; None = everything but `exclude_keys`.
    keys: ClassVar[frozenset[str] | None] = None
    exclude_keys: ClassVar[frozenset[str]] = frozenset()
    #: In a replay, take estimates in the order of the records they were made from
    #: (`edged.ordering.OrderedEstimates`), not in the order the workers' processes
    #: delivered them, for an output that puts several estimators' values side by
    #: side (the bridges): it then sends what live sent, whatever the workers' pace.
    #: Live, estimates go out as they come (a worker that lags never holds the others).
    ordered: ClassVar[bool] = False

    def check_estimators(self, configured: frozenset[str]) -> None:
        """Raise ValueError when the configuration names an estimator instance that is
        not among those `configured` (enabled or not): a configuration error naming
        the output's table, not an output that silently never sends."""

    @classmethod
    def own_marks(cls, config: Any) -> dict[str, frozenset[str]]:
        """What this output's traffic carries that marks it as edged's own, by mark
        (`nmea0183.talker`: the talker IDs it sends; `n2k.name`: its NAMEs): every
        input's decoder is given the union of all outputs' marks and refuses what
        bears one (DESIGN §4: edged never reads its own output back)."""
        return {}

    async def open(self) -> None:
        """Open sessions and files; raising makes the runtime retry with backoff."""

    def write(self, batch: list[Any]) -> None:
        """Take a batch of records (in publish order). Must not block for long."""
        raise NotImplementedError

    async def ready(self, timeout: float | None = None) -> bool:
        """True once the output can deliver (a publisher linked to its peers).

        A replay awaits every output's `ready()` before its first record, so that a
        subscriber gets the whole voyage; `timeout` None is the output's own bound.
        Returning False (not linked in time) lets the replay go on, with a warning.
        """
        return True

    def flush(self) -> None:
        """Called about once a second and before close."""

    def rotate(self) -> None:
        """SIGHUP: start new files."""

    async def close(self) -> None:
        """Flush and release everything; called once on shutdown or before restart."""

    # -- a process of its own that is killed (`worker = "process"`) ---------------------
    def ledger(self) -> dict[str, Any] | None:
        """(in the output's process) What its parent needs to count exactly what a
        kill of the process loses: sent with every answer, kept by the parent. None:
        the parent counts the records of the writes that got no answer."""
        return None

    def lost_at_death(self, handed: int, ledger: dict[str, Any] | None) -> int | None:
        """(in the parent, after the output's process died) How many of the `handed`
        records given to that process reached no destination, from its last `ledger`
        and what it left behind (a recorder's file); None: not known here (then the
        records of the writes that got no answer are counted)."""
        return None
