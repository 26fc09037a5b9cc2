"""A real signalk-server for the Signal K output's tests (issue 35).

`make signalk-server` installs it with npm under `.venv/signalk` (pinned in the
Makefile); `skip_reason()` says why a test cannot run it (no node, not installed).

`SignalKServer` starts one on 127.0.0.1 only: its HTTP socket is bound here, on a
port the kernel chooses, and handed to it as systemd's first socket (`LISTEN_FDS`,
fd 3), since signalk-server itself listens on every address. Its configuration
directory is a temporary one, with security off, no mDNS and none of its own
listeners (NMEA 0183 and Signal K over TCP on fixed ports), and one data connection:
a "Signal K" connection over TCP to `host:port`, where the output under test
serves. `get` and `poll` read its REST API without blocking the event loop.
"""

from __future__ import annotations

import asyncio
import json
import os
import re
import shutil
import socket
import subprocess
from pathlib import Path
from typing import Any, Callable

__all__ = ["ROOT", "SERVER_BIN", "skip_reason", "SignalKServer"]

#: Where `make signalk-server` installs it (npm's --prefix).
ROOT = Path(__file__).resolve().parents[2] / ".venv" / "signalk"
SERVER_BIN = ROOT / "node_modules" / "signalk-server" / "bin" / "signalk-server"
#: The oldest Node.js the pinned signalk-server runs on.
NODE_MAJOR = 20
#: The id of its data connection: the provider id it reports for what arrives on it.
CONNECTION_ID = "edged"


def skip_reason() -> str | None:
    """Why signalk-server cannot be run here, or None when it can."""
    if shutil.which("node") is None:
        return "node is not installed (signalk-server runs on Node.js)"
    version = subprocess.run(["node", "--version"], capture_output=True, text=True, timeout=10).stdout.strip()
    m = re.match(r"v(\d+)\.", version)
    if m is None or int(m.group(1)) < NODE_MAJOR:
        return f"node {version or '?'} is older than the {NODE_MAJOR} signalk-server needs"
    if not SERVER_BIN.exists():
        return f"signalk-server is not installed at {ROOT} (run `make signalk-server`; it needs npm)"
    if shutil.which("bash") is None:
        return "bash is needed to hand signalk-server its socket"
    return None


def settings(host: str, port: int) -> dict[str, Any]:
    """signalk-server's settings.json: one "Signal K" data connection over TCP."""
    connection = {
        "id": CONNECTION_ID,
        "enabled": True,
        "pipeElements": [{
            "type": "providers/simple",
            "options": {"logging": False, "type": "SignalK",
                        "subOptions": {"type": "tcp", "host": host, "port": port}},
        }],
    }
    off = ("nmea-tcp", "tcp", "appstore", "playground", "plugins", "webapps", "mfd_webapp", "logfiles")
    return {"interfaces": {name: False for name in off}, "mdns": False, "ssl": False,
            "pipedProviders": [connection]}


class SignalKServer:
    """One signalk-server process (see the module's docstring); `async with` it."""

    def __init__(self, config_dir: Path, host: str, port: int) -> None:
        self.config_dir = config_dir
        self.host, self.port = host, port
        self.http_port = 0
        self.log = config_dir / "server.log"
        self._proc: asyncio.subprocess.Process | None = None

    async def __aenter__(self) -> "SignalKServer":
        await self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()

    async def start(self) -> None:
        self.config_dir.mkdir(parents=True, exist_ok=True)
        (self.config_dir / "settings.json").write_text(json.dumps(settings(self.host, self.port)))
        http = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            http.bind(("127.0.0.1", 0))
            http.listen(16)
            self.http_port = http.getsockname()[1]
            fd = http.fileno()
            env = dict(os.environ, LISTEN_FDS="1", SIGNALK_NODE_CONFIG_DIR=str(self.config_dir),
                       HOME=str(self.config_dir), SKIP_ADMINUI_VERSION_CHECK="1")
            env.pop("LISTEN_PID", None)
            with open(self.log, "wb") as log:
                self._proc = await asyncio.create_subprocess_exec(
                    "bash", "-c", f'exec node "$0" 3<&{fd}', str(SERVER_BIN),
                    env=env, pass_fds=(fd,), stdin=asyncio.subprocess.DEVNULL, stdout=log,
                    stderr=asyncio.subprocess.STDOUT, start_new_session=True)
        finally:
            http.close()  # the server holds its own copy

    async def stop(self) -> None:
        p = self._proc
        if p is None or p.returncode is not None:
            return
        p.terminate()
        try:
            await asyncio.wait_for(p.wait(), 5.0)
        except asyncio.TimeoutError:
            p.kill()
            await p.wait()

    def log_tail(self, n: int = 3000) -> str:
        try:
            return self.log.read_text(errors="replace")[-n:]
        except OSError:
            return ""

    async def get(self, path: str, timeout: float = 2.0) -> tuple[int, Any]:
        """GET a path of its HTTP API: (status, the JSON body or None)."""
        async def fetch() -> bytes:
            reader, writer = await asyncio.open_connection("127.0.0.1", self.http_port)
            try:
                writer.write(f"GET {path} HTTP/1.0\r\nHost: 127.0.0.1\r\nAccept: application/json\r\n\r\n".encode())
                return await reader.read()  # HTTP/1.0: the body ends with the connection
            finally:
                writer.close()

        raw = await asyncio.wait_for(fetch(), timeout)
        head, _, body = raw.partition(b"\r\n\r\n")
        status = int(head.split(b" ", 2)[1])
        try:
            return status, json.loads(body) if body else None
        except ValueError:
            return status, None

    async def poll(self, path: str, ok: Callable[[Any], bool], timeout: float, interval: float = 0.05) -> Any:
        """GET `path` until `ok(body)` holds (every `interval` s), for at most `timeout`
        seconds; AssertionError then, with the last answer and the server's log."""
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        last: Any = None
        while True:
            if self._proc is not None and self._proc.returncode is not None:
                raise AssertionError(f"signalk-server exited ({self._proc.returncode}):\n{self.log_tail()}")
            try:
                status, body = await self.get(path)
                last = (status, body)
                if status == 200 and ok(body):
                    return body
            except (OSError, asyncio.TimeoutError, ValueError, IndexError) as exc:
                last = exc
            if loop.time() > end:
                raise AssertionError(f"GET {path}: not as expected in {timeout} s; last: {last!r}\n{self.log_tail()}")
            await asyncio.sleep(interval)
