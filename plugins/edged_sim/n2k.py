"""NMEA 2000 PGNs as CAN frames: the one encoder of this format.

Field layouts and resolutions follow canboat's PGN definitions (the reference every
open decoder uses): little-endian fields, unavailable values as all-ones (or the
signed maximum), reserved bits as ones. Payloads are built for a whole batch with
numpy structured arrays. 129029 is longer than a frame and goes out as a fast packet:
a first frame with the sequence counter, frame 0 and the length, then 7 data bytes
per frame, the last one padded with 0xFF.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

Values = Mapping[str, np.ndarray]

#: Resolution of each encoded value in SI (for tests): PGN -> field -> step.
RESOLUTION: dict[int, dict[str, float]] = {
    127250: {"heading": 1e-4},
    127251: {"r": 3.125e-8},
    127257: {"yaw": 1e-4, "pitch": 1e-4, "roll": 1e-4},
    129025: {"lat": 1e-7, "lon": 1e-7},
    129026: {"cog": 1e-4, "sog": 0.01},
    129029: {"lat": 1e-16, "lon": 1e-16},
}

#: Priorities as the standard recommends for these PGNs.
PRIORITY = {127250: 2, 127251: 2, 127257: 3, 129025: 2, 129026: 2, 129029: 3}


def can_id(pgn: int, source: int, priority: int) -> int:
    """29-bit identifier of a broadcast (PDU2) PGN."""
    return (priority & 7) << 26 | (pgn & 0x3FFFF) << 8 | (source & 0xFF)


def _q(x: np.ndarray, res: float, dtype: str) -> np.ndarray:
    """Scaled integer, clipped clear of the 'not available' codes at the top of the range."""
    info = np.iinfo(dtype)
    return np.clip(np.round(np.asarray(x) / res), info.min + (1 if info.min else 0), info.max - 2).astype(dtype)


def _pack(n: int, fields: list[tuple[str, str, object]]) -> np.ndarray:
    """Rows of a little-endian record: (name, dtype, values or constant)."""
    rec = np.zeros(n, dtype=[(name, "<" + dt if dt not in ("u1", "i1") else dt) for name, dt, _ in fields])
    for name, _, value in fields:
        rec[name] = value
    return rec.view(np.uint8).reshape(n, -1)


def _sid(idx: np.ndarray) -> np.ndarray:
    return (idx % 253).astype("u1")  # 253..255 are reserved


def p127250(idx: np.ndarray, t_ms: np.ndarray, v: Values) -> np.ndarray:
    """Vessel Heading: SID, heading 1e-4 rad, deviation, variation (n/a), reference true."""
    return _pack(idx.size, [("sid", "u1", _sid(idx)), ("hdg", "u2", _q(v["heading"], 1e-4, "u2")),
                            ("dev", "i2", 0x7FFF), ("var", "i2", 0x7FFF), ("ref", "u1", 0xFC)])


def p127251(idx: np.ndarray, t_ms: np.ndarray, v: Values) -> np.ndarray:
    """Rate of Turn: SID, rate 3.125e-8 rad/s signed, 3 reserved bytes."""
    return _pack(idx.size, [("sid", "u1", _sid(idx)), ("rate", "i4", _q(v["r"], 3.125e-8, "i4")),
                            ("r0", "u1", 0xFF), ("r1", "u1", 0xFF), ("r2", "u1", 0xFF)])


def p127257(idx: np.ndarray, t_ms: np.ndarray, v: Values) -> np.ndarray:
    """Attitude: SID, yaw, pitch, roll 1e-4 rad signed, reserved byte."""
    yaw = np.where(v["yaw"] > np.pi, v["yaw"] - 2 * np.pi, v["yaw"])  # signed field
    return _pack(idx.size, [("sid", "u1", _sid(idx)), ("yaw", "i2", _q(yaw, 1e-4, "i2")),
                            ("pitch", "i2", _q(v["pitch"], 1e-4, "i2")), ("roll", "i2", _q(v["roll"], 1e-4, "i2")),
                            ("res", "u1", 0xFF)])


def p129025(idx: np.ndarray, t_ms: np.ndarray, v: Values) -> np.ndarray:
    """Position, Rapid Update: latitude, longitude 1e-7 degree signed."""
    return _pack(idx.size, [("lat", "i4", _q(v["lat"], 1e-7, "i4")), ("lon", "i4", _q(v["lon"], 1e-7, "i4"))])


def p129026(idx: np.ndarray, t_ms: np.ndarray, v: Values) -> np.ndarray:
    """COG & SOG, Rapid Update: SID, reference true, COG 1e-4 rad, SOG 0.01 m/s."""
    return _pack(idx.size, [("sid", "u1", _sid(idx)), ("ref", "u1", 0xFC), ("cog", "u2", _q(v["cog"], 1e-4, "u2")),
                            ("sog", "u2", _q(v["sog"], 0.01, "u2")), ("res", "u2", 0xFFFF)])


def p129029(idx: np.ndarray, t_ms: np.ndarray, v: Values) -> np.ndarray:
    """GNSS Position Data (43 bytes, no reference stations): date, time, lat/lon 1e-16°,
    altitude n/a, GPS / GNSS fix, no integrity, SVs, HDOP/PDOP 0.01, geoidal separation."""
    days = (t_ms // 86_400_000).astype("u2")
    secs = ((t_ms % 86_400_000) * 10).astype("u4")  # 1e-4 s
    return _pack(idx.size, [
        ("sid", "u1", _sid(idx)), ("date", "u2", days), ("time", "u4", secs),
        ("lat", "i8", np.round(v["lat"] * 1e16).astype("i8")), ("lon", "i8", np.round(v["lon"] * 1e16).astype("i8")),
        ("alt", "i8", np.iinfo("i8").max), ("type", "u1", 0x10), ("integrity", "u1", 0xFC),
        ("svs", "u1", v["sats"].astype("u1")), ("hdop", "i2", _q(v["hdop"], 0.01, "i2")),
        ("pdop", "i2", _q(v["hdop"] * 1.5, 0.01, "i2")), ("geoid", "i4", 0), ("refs", "u1", 0),
    ])


def fast_packet(payloads: np.ndarray, seq: np.ndarray) -> np.ndarray:
    """Split equal-length payloads (n, L) into fast-packet frames (n, frames, 8)."""
    n, length = payloads.shape
    frames = 1 + max(0, -(-(length - 6) // 7))
    padded = np.full((n, 6 + 7 * (frames - 1)), 0xFF, dtype=np.uint8)
    padded[:, :length] = payloads
    out = np.empty((n, frames, 8), dtype=np.uint8)
    head = ((seq % 8) << 5).astype(np.uint8)
    out[:, 0, 0] = head
    out[:, 0, 1] = length
    out[:, 0, 2:] = padded[:, :6]
    for k in range(1, frames):
        out[:, k, 0] = head | k
        out[:, k, 1:] = padded[:, 6 + 7 * (k - 1): 6 + 7 * k]
    return out


@dataclass(frozen=True)
class Pgn:
    pgn: int
    payload: Callable[[np.ndarray, np.ndarray, Values], np.ndarray]
    fast: bool = False

    def frames(self, idx: np.ndarray, t_ms: np.ndarray, v: Values, source: int) -> tuple[int, np.ndarray]:
        """(CAN id, frames (n, per message, 8 bytes)) for a batch of samples."""
        data = self.payload(idx, t_ms, v)
        frames = fast_packet(data, idx) if self.fast else data[:, None, :]
        return can_id(self.pgn, source, PRIORITY[self.pgn]), frames


#: PGN encoders by number.
PGNS: dict[int, Pgn] = {
    p.pgn: p
    for p in (
        Pgn(127250, p127250), Pgn(127251, p127251), Pgn(127257, p127257),
        Pgn(129025, p129025), Pgn(129026, p129026), Pgn(129029, p129029, fast=True),
    )
}
