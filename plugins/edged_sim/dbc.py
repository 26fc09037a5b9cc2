"""The reference DBC frames of DESIGN §5 (11-bit ids, little-endian): one encoder.

Draft marks at 0x310–0x315 with a per-mark counter (+1 per sample, so a gap in the
counter is a lost frame), IMU accelerations, rates and attitude at 0x320–0x322.
Tests decode these frames with cantools and the reference DBC the CAN input ships, so
the encoder is checked against the one DBC.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from .truth import MARKS

Values = Mapping[str, np.ndarray]

#: Mark name -> DraftMark frame id.
DRAFT_IDS: dict[str, int] = {name: 0x310 + i for i, (name, _, _) in enumerate(MARKS)}

#: Signal resolutions (SI) for tests.
RESOLUTION = {"draft": 0.001, "ax": 0.001, "ay": 0.001, "az": 0.001, "yaw_rate": 1e-6,
              "roll_rate": 1e-4, "pitch_rate": 1e-4, "roll": 1e-4, "pitch": 1e-4, "heave": 0.001}


def _q(x: np.ndarray, res: float, dtype: str) -> np.ndarray:
    info = np.iinfo(dtype)
    return np.clip(np.round(np.asarray(x) / res), info.min, info.max).astype(dtype)


def _rows(n: int, fields: list[tuple[str, str, object]]) -> np.ndarray:
    rec = np.zeros(n, dtype=[(name, dt) for name, dt, _ in fields])
    for name, _, value in fields:
        rec[name] = value
    return rec.view(np.uint8).reshape(n, -1)


def draft_mark(idx: np.ndarray, v: Values) -> np.ndarray:
    draft = np.where(np.isfinite(v["draft"]), v["draft"], np.nan)
    raw = np.where(np.isnan(draft), 0xFFFF, np.clip(np.round(np.nan_to_num(draft) / 0.001), 0, 0xFFFE)).astype("<u2")
    return _rows(idx.size, [("draft", "<u2", raw), ("status", "u1", v["status"].astype("u1")),
                            ("counter", "u1", (idx % 256).astype("u1"))])


def imu_accel(idx: np.ndarray, v: Values) -> np.ndarray:
    return _rows(idx.size, [(k, "<i2", _q(v[k], 0.001, "i2")) for k in ("ax", "ay", "az")])


def imu_rate(idx: np.ndarray, v: Values) -> np.ndarray:
    return _rows(idx.size, [("yaw_rate", "<i4", _q(v["r"], 1e-6, "i4")),
                            ("roll_rate", "<i2", _q(v["roll_rate"], 1e-4, "i2")),
                            ("pitch_rate", "<i2", _q(v["pitch_rate"], 1e-4, "i2"))])


def imu_attitude(idx: np.ndarray, v: Values) -> np.ndarray:
    return _rows(idx.size, [("roll", "<i2", _q(v["roll"], 1e-4, "i2")), ("pitch", "<i2", _q(v["pitch"], 1e-4, "i2")),
                            ("heave", "<i2", _q(v["heave"], 0.001, "i2"))])


@dataclass(frozen=True)
class DbcFrame:
    name: str
    frame_id: int | None  #: None: the id depends on the sensor (draft mark)
    payload: object

    def frames(self, idx: np.ndarray, v: Values, mark: str) -> tuple[int, np.ndarray]:
        fid = DRAFT_IDS[mark] if self.frame_id is None else self.frame_id
        return fid, self.payload(idx, v)[:, None, :]  # type: ignore[operator]


#: DBC frame encoders by message name.
FRAMES: dict[str, DbcFrame] = {
    f.name: f
    for f in (
        DbcFrame("DraftMark", None, draft_mark),
        DbcFrame("ImuAccel", 0x320, imu_accel),
        DbcFrame("ImuRate", 0x321, imu_rate),
        DbcFrame("ImuAttitude", 0x322, imu_attitude),
    )
}
