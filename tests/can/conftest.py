"""Fixtures of the CAN input tests: health, decoders, and frame builders.

Frames are built by hand with `struct` from the NMEA 2000 / DESIGN §5 layouts, so the
tests check the decoder against the wire format, not against itself.
"""

from __future__ import annotations

import struct
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Callable

import pytest

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.records import Measurement, RawRecord
from edged_can.config import CanConfig
from edged_can.decoder import CanDecoder

REPO = Path(__file__).resolve().parents[2]
N2K_DATA = REPO.parent / "shared" / "data" / "n2k"


def n2k_id(pgn: int, src: int, prio: int = 2, dst: int = 255) -> int:
    """29-bit identifier: priority, PGN (PDU1 puts the destination in PS), source."""
    pf = (pgn >> 8) & 0xFF
    if pf < 240:
        pgn = (pgn & 0x3FF00) | dst
    return (prio << 26) | (pgn << 8) | src


def fast_frames(payload: bytes, seq: int = 0) -> list[bytes]:
    """Split a payload into fast-packet frames (padding 0xFF), as a sender would."""
    frames = [bytes([seq << 5, len(payload)]) + payload[:6]]
    rest = payload[6:]
    i = 1
    while rest:
        frames.append(bytes([(seq << 5) | i]) + rest[:7])
        rest = rest[7:]
        i += 1
    return [f.ljust(8, b"\xff") for f in frames]


def can_raw(can_id: int, data: bytes, t: float = 100.0, ext: bool | None = None, bus: str = "can0") -> RawRecord:
    if ext is None:
        ext = can_id > 0x7FF
    return RawRecord("can", bus, t, data, {"id": can_id, "ext": ext})


# Payloads of the navigation PGNs (little-endian, canboat layouts).
def pgn_127250(heading: float, deviation: float | None = None, variation: float | None = None, ref: int = 0) -> bytes:
    def ang(x: float | None) -> int:
        return 0x7FFF if x is None else round(x / 1e-4)

    return struct.pack("<BHhhB", 0, round(heading / 1e-4), ang(deviation), ang(variation), 0xFC | ref)


def pgn_129029(lat: float, lon: float, method: int = 1, sats: int = 9, hdop: float = 0.8,
               days: int = 20000, secs: float = 3600.0) -> bytes:
    return struct.pack(
        "<BHIqqqBBBhhiB",
        1, days, round(secs / 1e-4), round(lat / 1e-16), round(lon / 1e-16), 0,
        (method << 4) | 0, 0xFC, sats, round(hdop / 0.01), 0x7FFF, 0, 0,
    )


@pytest.fixture
def clock() -> ManualClock:
    return ManualClock(1000.0)


@pytest.fixture
def health(clock: ManualClock) -> ComponentHealth:
    return ComponentHealth("can0", "input", "can", clock)


@pytest.fixture
def make_decoder(health: ComponentHealth) -> Callable[..., CanDecoder]:
    def _make(bus: str = "can0", **cfg: Any) -> CanDecoder:
        return CanDecoder(bus, CanConfig.model_validate({"type": "can", **cfg}), health)

    return _make


@pytest.fixture
def decoder(make_decoder: Callable[..., CanDecoder]) -> CanDecoder:
    return make_decoder()


@pytest.fixture
def feed(decoder: CanDecoder) -> Callable[..., list[Measurement]]:
    """Decode records (RawRecords or (id, data) pairs) and return all measurements."""

    def _feed(*records: Any) -> list[Measurement]:
        out: list[Measurement] = []
        for r in records:
            raw = r if isinstance(r, RawRecord) else can_raw(*r)
            out += decoder.decode(raw)
        return out

    return _feed


@pytest.fixture
def n2k_data() -> Path:
    if not N2K_DATA.is_dir():
        pytest.skip(f"../shared data not here: {N2K_DATA} not found")
    return N2K_DATA


@pytest.fixture
def build() -> SimpleNamespace:
    """The frame builders above (test modules cannot import conftest by name)."""
    return SimpleNamespace(
        n2k_id=n2k_id,
        fast_frames=fast_frames,
        raw=can_raw,
        pgn_127250=pgn_127250,
        pgn_129029=pgn_129029,
    )


@pytest.fixture
def make_health(clock: ManualClock) -> Callable[[str], ComponentHealth]:
    return lambda name: ComponentHealth(name, "input", "can", clock)
