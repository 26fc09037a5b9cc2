"""The Foxglove output's tests: outputs on 127.0.0.1 with a port the kernel chooses,
and a plain WebSocket client that speaks the Foxglove protocol itself (serverInfo,
advertise, subscribe with subscription ids, binary message data), so that what a
browser would get is checked without the SDK on the client side."""

from __future__ import annotations

import asyncio
import json
import struct
from collections import deque
from typing import Any, AsyncIterator, Awaitable, Callable

import pytest
import websockets
from bridge_rig import Ctx
from edged_foxglove.output import FoxgloveOutput

#: Seconds any single wait may take before the test fails (nothing here takes long).
TIMEOUT = 5.0
#: Both names of the protocol; the SDK's server picks the one it speaks.
SUBPROTOCOLS = ["foxglove.websocket.v1", "foxglove.sdk.v1"]
_DATA = struct.Struct("<BIQ")  # opcode 0x01, subscription id, log time (ns)


class FoxClient:
    """A Foxglove WebSocket client: channels as advertised, messages as received."""

    def __init__(self, ws: Any) -> None:
        self.ws = ws
        self.server_info: dict[str, Any] | None = None
        self.channels: dict[str, dict[str, Any]] = {}  # topic -> its advertisement
        self.subs: dict[int, str] = {}  # subscription id -> topic
        self._binary: deque[bytes] = deque()

    async def _read(self) -> None:
        raw = await asyncio.wait_for(self.ws.recv(), TIMEOUT)
        if isinstance(raw, bytes):
            self._binary.append(raw)
            return
        msg = json.loads(raw)
        if msg["op"] == "serverInfo":
            self.server_info = msg
        elif msg["op"] == "advertise":
            for ch in msg["channels"]:
                self.channels[ch["topic"]] = ch
        elif msg["op"] == "unadvertise":
            gone = set(msg["channelIds"])
            self.channels = {t: c for t, c in self.channels.items() if c["id"] not in gone}

    async def info(self) -> dict[str, Any]:
        while self.server_info is None:
            await self._read()
        return self.server_info

    async def channel(self, topic: str) -> dict[str, Any]:
        """The advertisement of `topic`, once it came."""
        while topic not in self.channels:
            await self._read()
        return self.channels[topic]

    async def subscribe(self, out: FoxgloveOutput, *topics: str) -> None:
        """Subscribe to `topics` and return once the server has the subscriptions."""
        subs = []
        wanted = {topic: out.watchers(topic) + 1 for topic in topics}
        for topic in topics:
            ch = await self.channel(topic)
            sid = len(self.subs) + 100  # ids of the client's own choosing
            self.subs[sid] = topic
            subs.append({"id": sid, "channelId": ch["id"]})
        await self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
        for topic in topics:
            await asyncio.wait_for(out.watched(topic, wanted[topic]), TIMEOUT)

    async def message(self) -> tuple[str, int, bytes]:
        """The next message data: (topic, log time in ns, payload bytes)."""
        while not self._binary:
            await self._read()
        frame = self._binary.popleft()
        op, sid, log_ns = _DATA.unpack_from(frame)
        assert op == 0x01, f"binary opcode {op:#x} is not message data"
        return self.subs[sid], log_ns, frame[_DATA.size:]

    async def messages_until(self, topic: str, log_ns: int | None = None) -> list[tuple[str, int, bytes]]:
        """Messages up to and including the first one on `topic` (logged at `log_ns`
        when given): a sentinel written last (a client's messages keep their order)."""
        got = []
        while True:
            m = await self.message()
            got.append(m)
            if m[0] == topic and log_ns in (None, m[1]):
                return got


@pytest.fixture
async def fox() -> AsyncIterator[Callable[..., Awaitable[tuple[FoxgloveOutput, Ctx]]]]:
    """Open a Foxglove output from config keys (port 0 unless given); all closed after."""
    made: list[FoxgloveOutput] = []

    async def make(**cfg: Any) -> tuple[FoxgloveOutput, Ctx]:
        c = Ctx("fox", "foxglove")
        out = FoxgloveOutput(FoxgloveOutput.Config.model_validate({"type": "foxglove", "port": 0, **cfg}), c.ctx)
        made.append(out)
        await out.open()
        return out, c

    yield make
    for out in made:
        await out.close()


@pytest.fixture
async def client() -> AsyncIterator[Callable[[FoxgloveOutput], Awaitable[FoxClient]]]:
    """Connect a FoxClient to an open output; all disconnected after."""
    opened: list[Any] = []

    async def connect(out: FoxgloveOutput) -> FoxClient:
        assert out.port
        ws = await asyncio.wait_for(websockets.connect(f"ws://127.0.0.1:{out.port}", subprotocols=SUBPROTOCOLS),
                                    TIMEOUT)
        opened.append(ws)
        fc = FoxClient(ws)
        await fc.info()
        return fc

    yield connect
    for ws in opened:
        await ws.close()
