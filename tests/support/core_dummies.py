"""Dummy plugins exercising the core without any sensor, transport or filter."""

from __future__ import annotations

import asyncio
import os
import sys
import time
from typing import Any, BinaryIO, Iterator

from edged.plugin import (
    EstimatorPlugin,
    InputConfig,
    InputPlugin,
    OutputConfig,
    OutputPlugin,
    ReplayOptions,
)
from edged.estimator import ESTIMATES, Estimator, handles
from edged.health import ComponentHealth
from edged.records import Estimate, Measurement, RawRecord


class DummyDecoder:
    """`<t> <kind> <field>=<value>` lines -> one measurement each."""

    def __init__(self, source: str, health: ComponentHealth) -> None:
        self.source = source
        self.health = health

    def decode(self, raw: RawRecord) -> list[Measurement]:
        try:
            _, kind, kv = raw.data.decode().split()
            k, v = kv.split("=")
            m = Measurement(kind, self.source, raw.t, {k: float(v)})
        except ValueError:
            self.health.count("rejected.syntax")
            return []
        self.health.count(f"measurements.{kind}")
        return [m]


class DummyInputConfig(InputConfig):
    lines: list[str] = []
    fail_times: int = 0


class DummyInput(InputPlugin):
    """Emits its configured lines, optionally failing the first `fail_times` runs."""

    Config = DummyInputConfig
    protocol = "dummy"
    runs = 0

    async def run(self) -> None:
        type(self).runs += 1
        if type(self).runs <= self.config.fail_times:
            raise RuntimeError(f"boom {type(self).runs}")
        for line in self.config.lines:
            t = float(line.split()[0])
            self.ctx.ingest(RawRecord("dummy", self.ctx.name, t, line.encode()))
        await asyncio.Event().wait()

    @classmethod
    def make_decoder(cls, source: str, config: Any, health: ComponentHealth, own: Any = None) -> DummyDecoder:
        return DummyDecoder(source, health)


class DummyLog:
    """The log reader of `#dummy` files: `<t> <kind> <field>=<value>` lines, decoded
    by the `dummy` input (registered as log reader `dummy`)."""

    name = "dummy"
    protocol = "dummy"
    input = "dummy"
    priority = 50

    def sniff(self, head: bytes) -> bool:
        return head.startswith(b"#dummy")

    def open(
        self, stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
    ) -> Iterator[RawRecord]:
        for raw in stream:
            line = raw.strip()
            if not line or line.startswith(b"#"):
                continue
            try:
                t = float(line.split()[0])
            except ValueError:
                health.count("rejected.no_time")
                continue
            health.count("lines")
            yield RawRecord("dummy", source, t, line)


class SumConfig(EstimatorPlugin.Config):  # type: ignore[name-defined,misc]
    fail_on: float | None = None


class SumCore(Estimator):
    """Running sum of `yaw_rate.r`; raises on the value `fail_on`."""

    def __init__(self, cfg: SumConfig) -> None:
        super().__init__(cfg)
        self.total = 0.0
        self.fail_on = cfg.fail_on
        #: Times of the yaw rates summed, in the order stepped.
        self.times: list[float] = []

    @handles("yaw_rate")
    def _yaw_rate(self, rec: Measurement) -> list[Estimate]:
        if self.fail_on is not None and rec.values.get("r") == self.fail_on:
            raise ValueError("bad value")
        self.times.append(rec.t)
        self.total += rec.values["r"]
        return [Estimate("sum", "sum", rec.t, {"total": self.total})]


class ChainConfig(EstimatorPlugin.Config):  # type: ignore[name-defined,misc]
    #: The estimator instance whose estimates it consumes.
    upstream: str = "sum"


class ChainCore(Estimator):
    """Consumes an upstream estimate and the raw yaw rate: order-sensitive on purpose
    (a trace of what came in, and a running value that any reordering changes)."""

    @classmethod
    def upstream(cls, config: ChainConfig) -> tuple[str, ...]:
        return (config.upstream,)

    def __init__(self, cfg: ChainConfig) -> None:
        super().__init__(cfg)
        self.trace: list[str] = []
        self.value = 0.0

    @handles(ESTIMATES)
    def _estimate(self, rec: Estimate) -> list[Estimate]:
        return self._advance(rec, rec.values["total"])

    @handles("yaw_rate")
    def _yaw_rate(self, rec: Measurement) -> list[Estimate]:
        return self._advance(rec, rec.values["r"])

    def _advance(self, rec: Measurement | Estimate, x: float) -> list[Estimate]:
        self.trace.append(rec.route_key)
        self.value = 0.9 * self.value + x
        trace = "".join(k[0] for k in self.trace[-16:])
        return [Estimate("chain", "chain", rec.t, {"trace": trace, "value": self.value})]


class SumEstimator(EstimatorPlugin):
    Config = SumConfig
    Core = SumCore
    #: Every core made, in order (a test reads what each one summed).
    cores: list[SumCore] = []

    def make_core(self) -> SumCore:
        core = super().make_core()
        assert isinstance(core, SumCore)
        SumEstimator.cores.append(core)
        return core


class ChainEstimator(EstimatorPlugin):
    Config = ChainConfig
    Core = ChainCore


class MeanConfig(EstimatorPlugin.Config):  # type: ignore[name-defined,misc]
    #: Seconds each step sleeps (a deliberately slow filter).
    step_delay: float = 0.0
    #: A yaw rate on which the core hangs for `hang_for` seconds.
    hang_on: float | None = None
    hang_for: float = 60.0
    #: Publish only on ticks (the core `TickingMeanCore`).
    tick_only: bool = False


class MeanCore(Estimator):
    """Mean of the yaw rates seen, with its own health: NIS of each update, a gate
    for |r| > 1 rad/s, a reset when r is exactly 0.5, and a problem named while the
    latest r is negative."""

    nis_window = 10

    def __init__(self, cfg: MeanConfig) -> None:
        super().__init__(cfg)
        self.n = 0
        self.mean = 0.0
        self.last_r = 0.0

    @handles("yaw_rate")
    def _yaw_rate(self, rec: Measurement) -> list[Estimate]:
        r = rec.values["r"]
        self.last_r = r
        if self.cfg.step_delay:
            time.sleep(self.cfg.step_delay)
        if self.cfg.hang_on is not None and r == self.cfg.hang_on:
            print("event=core-hangs", file=sys.stderr, flush=True)  # for a test that signals it now
            time.sleep(self.cfg.hang_for)
        if abs(r) > 1.0:
            self.gated("yaw_rate")
            return []
        if r == 0.5:
            self.reset("r was 0.5", rec.t)
        self.updated("yaw_rate", (r - self.mean) ** 2, 1)
        self.n += 1
        self.mean += (r - self.mean) / self.n
        return [] if self.cfg.tick_only else [self._estimate(rec.t)]

    def _estimate(self, t: float) -> Estimate:
        return Estimate("x", "x", t, {"mean": self.mean, "n": self.n})

    def problems(self) -> list[str]:
        return [f"yaw_rate/gyro: r {self.last_r} is negative"] if self.last_r < 0 else []


class TickingMeanCore(MeanCore):
    """The mean published at the ticks only (`tick_only`)."""

    def tick(self, t: float) -> list[Estimate]:
        return [self._estimate(t)]


class MeanEstimator(EstimatorPlugin):
    Config = MeanConfig
    kind = "stw"  # any defined kind: the host stamps it on every estimate

    def core_class(self) -> type[MeanCore]:
        return TickingMeanCore if self.config.tick_only else MeanCore


class ListOutputConfig(OutputConfig):
    fail_writes: int = 0
    missing_file: str | None = None


class ListOutput(OutputPlugin):
    """Keeps what it receives; records its lifecycle for assertions."""

    Config = ListOutputConfig
    instances: list["ListOutput"] = []

    def __init__(self, config: Any, ctx: Any) -> None:
        super().__init__(config, ctx)
        self.records: list[Any] = []
        self.events: list[str] = []
        self.got_first = asyncio.Event()
        ListOutput.instances.append(self)

    def check(self) -> None:
        if self.config.missing_file:
            raise ValueError(f"{self.config.missing_file}: no such file")

    async def open(self) -> None:
        self.events.append("open")

    def write(self, batch: list[Any]) -> None:
        if self.config.fail_writes > sum(1 for e in self.events if e == "write-failed"):
            self.events.append("write-failed")
            raise OSError(28, "No space left on device")
        self.records.extend(batch)
        self.got_first.set()

    def flush(self) -> None:
        self.events.append("flush")

    def rotate(self) -> None:
        self.events.append("rotate")

    async def close(self) -> None:
        self.events.append("close")


class FileOutputConfig(OutputConfig):
    #: One line per call and record, flushed at once (the test reads it after).
    path: str
    #: A record with this time makes the process exit at once (a crash).
    crash_at: float | None = None
    #: A record with this time makes `write` raise (the plugin fails, the process lives).
    raise_at: float | None = None
    #: `open` raises (a file that cannot be made, a server that refuses).
    fail_open: bool = False


class FileOutput(OutputPlugin):
    """An output meant for `worker = "process"`: what it is given is seen in its file,
    its health and its log, from whichever process it runs in."""

    Config = FileOutputConfig

    def _line(self, text: str) -> None:
        with open(self.config.path, "a") as f:
            f.write(f"{os.getpid()} {text}\n")

    async def open(self) -> None:
        self._line("open")
        if self.config.fail_open:
            raise OSError("the disk said no")
        self.ctx.health.set_state("writing")
        self.ctx.health.info["pid"] = os.getpid()
        self.ctx.health.info["config_dir"] = str(self.ctx.config_dir)
        self.ctx.log.info("event=file-output-open pid=%d", os.getpid())

    def write(self, batch: list[Any]) -> None:
        for rec in batch:
            if rec.t == self.config.crash_at:
                os._exit(3)
            if rec.t == self.config.raise_at:
                self.ctx.health.error(f"refused t={rec.t}")
                raise ValueError(f"record at t={rec.t} refused")
            self._line(f"write {type(rec).__name__} {rec.t!r} {self.ctx.clock.now()!r}")
            self.ctx.health.count("seen")

    def flush(self) -> None:
        self._line("flush")

    def rotate(self) -> None:
        self._line("rotate")

    def status(self) -> dict[str, Any]:
        return {"lines_pid": os.getpid()}

    async def close(self) -> None:
        self._line("close")
