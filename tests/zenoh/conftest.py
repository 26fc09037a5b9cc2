"""Fixtures of the zenoh tests: ports, plugin contexts and line-driven subprocesses.

Every endpoint is on 127.0.0.1 on a port the test picks (bind port 0); subprocesses
are synchronised through their stdout lines, with timeouts only as a safety net.
"""

from __future__ import annotations

import os
import queue
import socket
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any, Callable, Iterator

import pytest

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
PYTHON = sys.executable
SAFETY = 30.0  # seconds: a safety net, never the synchronisation itself


def pick_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def free_port() -> Callable[[], int]:
    return pick_port


class Ctx:
    """A PluginContext whose published records are collected in `published`."""

    def __init__(self, name: str, vessel_id: str, options: dict[str, Any] | None = None) -> None:
        self.clock = ManualClock(1_732_350_000.0)
        self.health = ComponentHealth(name, "plugin", "zenoh", self.clock)
        self.published: list[Any] = []
        self.ctx = PluginContext(
            name=name,
            clock=self.clock,
            health=self.health,
            publish=self.published.append,
            vessel_id=vessel_id,
            config_dir=REPO,
            options=dict(options or {}),
        )


@pytest.fixture
def make_ctx() -> Callable[..., Ctx]:
    return Ctx


class LineProc:
    """A subprocess whose stdout lines are read by a thread into a queue."""

    def __init__(self, argv: list[str], **kw: Any) -> None:
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen(
            argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True, env=env, cwd=REPO, **kw,
        )
        self.lines: queue.Queue[str | None] = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._pump, daemon=True).start()

    def _pump(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.put(line.rstrip("\n"))
        self.lines.put(None)

    def expect(self, pred: Callable[[str], bool], timeout: float = SAFETY) -> str:
        """The next line satisfying `pred` (earlier lines are kept in `seen`)."""
        while True:
            try:
                line = self.lines.get(timeout=timeout)
            except queue.Empty:
                raise AssertionError(f"no expected line within {timeout} s; seen: {self.seen[-20:]}") from None
            if line is None:
                err = self.proc.stderr.read() if self.proc.stderr else ""
                raise AssertionError(f"process ended; seen: {self.seen[-20:]}; stderr: {err[-2000:]}")
            self.seen.append(line)
            if pred(line):
                return line

    def send(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def stop(self) -> None:
        if self.proc.poll() is None:
            try:
                self.send("quit")
            except (BrokenPipeError, OSError):
                pass
            for ask in (lambda: None, self.proc.terminate, self.proc.kill):
                ask()
                try:
                    self.proc.wait(timeout=3)
                    break
                except subprocess.TimeoutExpired:
                    continue


@pytest.fixture
def spawn() -> Iterator[Callable[..., LineProc]]:
    procs: list[LineProc] = []

    def _spawn(*argv: str) -> LineProc:
        p = LineProc(list(argv))
        procs.append(p)
        return p

    yield _spawn
    for p in procs:
        p.stop()


@pytest.fixture
def zpeer(spawn: Callable[..., LineProc]) -> Callable[..., LineProc]:
    """Start tests/zenoh/zpeer.py with the given arguments."""

    def _start(*args: str) -> LineProc:
        return spawn(PYTHON, str(HERE / "zpeer.py"), *args)

    return _start


@pytest.fixture
def router_proc(spawn: Callable[..., LineProc], tmp_path: Path) -> Callable[[int], LineProc]:
    """`edged router` (the real command line) listening on 127.0.0.1:<port>."""

    def _start(port: int) -> LineProc:
        cfg = tmp_path / f"router-{port}.json5"
        cfg.write_text('{\n  // test router\n  listen: { endpoints: ["tcp/127.0.0.1:%d"] },\n}\n' % port)
        return spawn(PYTHON, "-m", "edged.cli", "router", "--zenoh-config", str(cfg))

    return _start
