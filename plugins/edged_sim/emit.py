"""From sensor values to records on a bus: the table of output formats.

An output key `<format>:<message>` names the encoder (`nmea:GGA`, `n2k:129029`,
`dbc:DraftMark`); each format's adapter turns a batch of samples into records — NMEA
sentences or CAN frames — stamped in integer microseconds, so that ordering and the
printed times are exact and a run is reproducible to the byte.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from . import dbc, n2k, nmea0183
from .sensors import SensorSpec

Values = Mapping[str, np.ndarray]
FAST_PACKET_GAP_US = 500  #: one 8-byte extended frame at 250 kbit/s takes about 0.5 ms


@dataclass
class Batch:
    """Records of one bus: time (µs), a tie-break key, and the payloads."""

    t_us: np.ndarray
    key: np.ndarray
    payload: list = field(default_factory=list)  #: str (NMEA) or (id, extended, bytes) (CAN)

    @staticmethod
    def empty() -> "Batch":
        return Batch(np.zeros(0, np.int64), np.zeros(0, np.int64), [])

    @staticmethod
    def merge(batches: list["Batch"]) -> "Batch":
        """All records in time order; records at the same instant keep the suite's order."""
        batches = [b for b in batches if b.t_us.size]
        if not batches:
            return Batch.empty()
        t = np.concatenate([b.t_us for b in batches])
        k = np.concatenate([b.key for b in batches])
        p = [x for b in batches for x in b.payload]
        order = np.lexsort((k, t))
        return Batch(t[order], k[order], [p[i] for i in order.tolist()])


def _nmea(message: str) -> Callable[..., tuple[str, Batch]]:
    encode = nmea0183.ENCODERS[message]

    def out(spec: SensorSpec, idx: np.ndarray, t_ms: np.ndarray, v: Values, key: int) -> tuple[str, Batch]:
        lines = nmea0183.sentences(encode(spec.talker, t_ms, v))
        return "nmea", Batch(t_ms * 1000, np.full(t_ms.size, key, np.int64), lines)

    return out


def _frames(fid: int, extended: bool, frames: np.ndarray, t_ms: np.ndarray, key: int) -> Batch:
    n, per, dlc = frames.shape
    t = (t_ms[:, None] * 1000 + np.arange(per)[None, :] * FAST_PACKET_GAP_US).reshape(-1)
    buf = frames.reshape(n * per, dlc).tobytes()
    payload = [(fid, extended, buf[i * dlc:(i + 1) * dlc]) for i in range(n * per)]
    return Batch(t, np.full(t.size, key, np.int64), payload)


def _n2k(message: str) -> Callable[..., tuple[str, Batch]]:
    pgn = n2k.PGNS[int(message)]

    def out(spec: SensorSpec, idx: np.ndarray, t_ms: np.ndarray, v: Values, key: int) -> tuple[str, Batch]:
        fid, frames = pgn.frames(idx, t_ms, v, spec.address)
        return "can", _frames(fid, True, frames, t_ms, key)

    return out


def _dbc(message: str) -> Callable[..., tuple[str, Batch]]:
    frame = dbc.FRAMES[message]

    def out(spec: SensorSpec, idx: np.ndarray, t_ms: np.ndarray, v: Values, key: int) -> tuple[str, Batch]:
        fid, frames = frame.frames(idx, v, spec.mark)
        return "can", _frames(fid, False, frames, t_ms, key)

    return out


#: Output adapters by format prefix.
FORMATS: dict[str, Callable[[str], Callable[..., tuple[str, Batch]]]] = {"nmea": _nmea, "n2k": _n2k, "dbc": _dbc}


def output(key: str) -> Callable[..., tuple[str, Batch]]:
    """The adapter for an output key such as `nmea:GGA`."""
    fmt, _, message = key.partition(":")
    return FORMATS[fmt](message)
