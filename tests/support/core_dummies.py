"""Dummy plugins exercising the core without any sensor, transport or filter."""

from __future__ import annotations

import asyncio
import os
from typing import Any, BinaryIO, Iterator

from edged.plugin import (
    EstimatorPlugin,
    InputConfig,
    InputPlugin,
    OutputConfig,
    OutputPlugin,
    ReplayOptions,
)
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
    def make_decoder(cls, source: str, config: Any, health: ComponentHealth) -> DummyDecoder:
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


class SumCore:
    """Running sum of `yaw_rate.r`; also re-emits upstream estimates it consumes."""

    inputs = frozenset({"yaw_rate"})

    def __init__(self, fail_on: float | None) -> None:
        self.total = 0.0
        self.fail_on = fail_on
        self.seen: list[float] = []

    def step(self, rec: Measurement | Estimate) -> list[Estimate]:
        if self.fail_on is not None and rec.values.get("r") == self.fail_on:
            raise ValueError("bad value")
        self.seen.append(rec.t)
        self.total += rec.values["r"]
        return [Estimate("sum", "sum", rec.t, {"total": self.total})]


class ChainCore:
    """Consumes an upstream estimate and the raw yaw rate: order-sensitive on purpose
    (a trace of what came in, and a running value that any reordering changes)."""

    def __init__(self, upstream: str) -> None:
        self.upstream = upstream
        self.inputs = frozenset({f"est/{upstream}", "yaw_rate"})
        self.trace: list[str] = []
        self.value = 0.0

    def step(self, rec: Measurement | Estimate) -> list[Estimate]:
        self.trace.append(rec.route_key)
        x = rec.values["total"] if isinstance(rec, Estimate) else rec.values["r"]
        self.value = 0.9 * self.value + x
        return [
            Estimate("chain", "chain", rec.t, {"trace": "".join(k[0] for k in self.trace[-16:]), "value": self.value})
        ]


class SumConfig(EstimatorPlugin.Config):  # type: ignore[name-defined,misc]
    fail_on: float | None = None


class SumEstimator(EstimatorPlugin):
    Config = SumConfig
    cores: list[SumCore] = []

    def make_core(self) -> SumCore:
        core = SumCore(self.config.fail_on)
        SumEstimator.cores.append(core)
        return core


class ChainConfig(EstimatorPlugin.Config):  # type: ignore[name-defined,misc]
    #: The estimator instance whose estimates it consumes.
    upstream: str = "sum"


class ChainEstimator(EstimatorPlugin):
    Config = ChainConfig

    def make_core(self) -> ChainCore:
        return ChainCore(self.config.upstream)


class MeanConfig(EstimatorPlugin.Config):  # type: ignore[name-defined,misc]
    #: Seconds each step sleeps (a deliberately slow filter).
    step_delay: float = 0.0
    #: A yaw rate on which the core hangs for `hang_for` seconds.
    hang_on: float | None = None
    hang_for: float = 60.0
    #: Publish only on ticks (a core with `tick`).
    tick_only: bool = False


class MeanCore:
    """Mean of the yaw rates seen, with its own health: NIS of each update, a gate
    for |r| > 1 rad/s, a reset when r is exactly 0.5, and a problem named while the
    latest r is negative."""

    inputs = frozenset({"yaw_rate"})

    def __init__(self, cfg: MeanConfig) -> None:
        from edged.innovation import InnovationMonitor

        self.cfg = cfg
        self.n = 0
        self.mean = 0.0
        self.last_r = 0.0
        self.monitor = InnovationMonitor(window=10)
        if cfg.tick_only:
            self.tick = self._tick

    def step(self, rec: Measurement | Estimate) -> list[Estimate]:
        import time

        r = rec.values["r"]
        self.last_r = r
        if self.cfg.step_delay:
            time.sleep(self.cfg.step_delay)
        if self.cfg.hang_on is not None and r == self.cfg.hang_on:
            import sys

            print("event=core-hangs", file=sys.stderr, flush=True)  # for a test that signals it now
            time.sleep(self.cfg.hang_for)
        if abs(r) > 1.0:
            self.monitor.gated("yaw_rate")
            return []
        if r == 0.5:
            self.monitor.reset("r was 0.5", rec.t)
        self.monitor.update("yaw_rate", (r - self.mean) ** 2, 1)
        self.n += 1
        self.mean += (r - self.mean) / self.n
        return [] if self.cfg.tick_only else [Estimate("x", "x", rec.t, {"mean": self.mean, "n": self.n})]

    def _tick(self, t: float) -> list[Estimate]:
        return [Estimate("x", "x", t, {"mean": self.mean, "n": self.n})]

    def health(self) -> dict[str, Any]:
        out = self.monitor.snapshot()
        out["problems"] = [f"yaw_rate/gyro: r {self.last_r} is negative"] if self.last_r < 0 else []
        return out


class MeanEstimator(EstimatorPlugin):
    Config = MeanConfig
    kind = "stw"  # any defined kind: the host stamps it on every estimate

    def make_core(self) -> MeanCore:
        return MeanCore(self.config)


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


class FileOutput(OutputPlugin):
    """An output meant for `worker = "process"`: what it is given is seen in its file,
    its health and its log, from whichever process it runs in."""

    Config = FileOutputConfig

    def _line(self, text: str) -> None:
        with open(self.config.path, "a") as f:
            f.write(f"{os.getpid()} {text}\n")

    async def open(self) -> None:
        self._line("open")
        self.ctx.health.set_state("writing")
        self.ctx.health.info["pid"] = os.getpid()
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
