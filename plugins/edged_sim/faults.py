"""Deliberate damage to the logs, counted by reason so tests can check the rejects.

Only damage an input must *reject* is injected here (bad checksums, garbage lines,
values that cannot be true, truncated frames). Lost samples and position jumps are
sensor errors (`SensorSpec.dropout/outages/jumps`): an input passes those on and the
estimators judge them, so they are recorded separately.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from .nmea0183 import checksums

_GARBAGE = np.frombuffer(b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789 ,.;:-_#%&()=?+", dtype=np.uint8)


@dataclass(frozen=True)
class FaultSpec:
    """Probabilities per sentence or frame of each kind of damage."""

    bad_checksum: float = 0.0  #: a sentence's checksum no longer matches
    garbage: float = 0.0  #: a line of noise (no TAG block, no sentence) follows a sentence
    impossible: float = 0.0  #: a GGA reports a latitude beyond 90°
    bad_length: float = 0.0  #: a DBC frame arrives truncated to 2 bytes

    @property
    def any(self) -> bool:
        return any((self.bad_checksum, self.garbage, self.impossible, self.bad_length))


def damage_nmea(sentences: list[str], spec: FaultSpec, rng: np.random.Generator, counts: Counter) -> tuple[list[str], list[int]]:
    """Damage sentences in place; returns them and the positions after which a garbage
    line is to be inserted (the caller stamps it like its neighbour)."""
    n = len(sentences)
    if not spec.any or n == 0:
        return sentences, []
    u = rng.uniform(size=(n, 3))
    # One kind of damage per sentence, so that each maps onto exactly one reject.
    for i in np.flatnonzero((u[:, 0] < spec.impossible) & (u[:, 1] >= spec.bad_checksum)).tolist():
        s = sentences[i]
        parts = s[1:s.index("*")].split(",")
        if parts[0][2:] != "GGA":
            continue
        parts[2] = "91" + parts[2][2:]
        body = ",".join(parts)
        sentences[i] = f"${body}*{checksums([body])[0]}"
        counts["impossible_value"] += 1
    for i in np.flatnonzero(u[:, 1] < spec.bad_checksum).tolist():
        s = sentences[i]
        good = int(s[-2:], 16)
        sentences[i] = f"{s[:-2]}{good ^ int(rng.integers(1, 256)):02X}"
        counts["bad_checksum"] += 1
    garbage_after = np.flatnonzero(u[:, 2] < spec.garbage).tolist()
    counts["garbage"] += len(garbage_after)
    return sentences, garbage_after


def garbage_line(rng: np.random.Generator) -> str:
    return _GARBAGE[rng.integers(0, _GARBAGE.size, int(rng.integers(8, 60)))].tobytes().decode("ascii")


def damage_frames(sizes: int, spec: FaultSpec, rng: np.random.Generator, counts: Counter) -> np.ndarray:
    """Mask of DBC frames to truncate."""
    if spec.bad_length <= 0.0 or sizes == 0:
        return np.zeros(sizes, dtype=bool)
    mask = rng.uniform(size=sizes) < spec.bad_length
    counts["bad_length"] += int(mask.sum())
    return mask
