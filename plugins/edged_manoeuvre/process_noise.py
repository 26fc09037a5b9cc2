"""The process noise Q the filter predicts with: the configured density, scaled per
group of states by the NIS of the sensor that drives the group (`adaptive.QScale`).

GROUPS: which states' process noise each group scales, and the sensors whose NIS
drives it, in order of preference: the first that has updated in the last
`DRIVER_SPAN` s drives it alone. Each group listens to the sensor that sees its states
most directly: a rudder order shows first in the rate of turn (in the heading when
there is no rate sensor), an engine order or a turn's sway in the accelerometers (in
the positions without them). Pooling sensors would let a consistent one hide another's
inconsistency: a 0.1° heading's NIS barely moves when the yaw noise is ten times too
high, a 0.005°/s gyro's does. And the sensor that drives a group does not also have to
learn its own noise from the same NIS: the GNSS's is then learned against a process
noise the accelerometers have fixed.
"""

from __future__ import annotations

import math

import numpy as np

from .adaptive import QScale
from .cmm import Cmm
from .config import ManoeuvreConfig
from .ctra import Ctra
from .model import R

GROUPS = {
    "yaw": (("yaw_rate", "heading"), (5,)),
    "translation": (("accel", "velocity", "position"), (2, 3, 6, 7)),
}
DRIVER_SPAN = 5.0


class ProcessNoise:
    """Qc (the configured continuous-time density, diagonal) and its groups' scales."""

    def __init__(self, cfg: ManoeuvreConfig, model: Ctra | Cmm) -> None:
        bias = bool(cfg.imu_bias)
        yaw = model.yaw
        q = [cfg.q_position, cfg.q_position, cfg.q_velocity, cfg.q_velocity, cfg.q_heading,
             cfg.q_yaw_accel, cfg.q_jerk, cfg.jerk_v()] + [cfg.q_bias] * (2 if bias else 0)
        q += [cfg.q_yaw_jerk] * yaw.size
        self.Qc = np.diag(np.asarray(q, dtype=float))
        self.yaw_index = yaw.index
        #: The states whose process noise each adaptation group scales (`Q`).
        self.group_states = {g: states for g, (_, states) in GROUPS.items()}
        self._gyro_states = {**self.group_states, "yaw": (yaw.index,)} if yaw.index is not None else None
        # An ensemble's spread is its covariance: lowering the noise that keeps the
        # members apart collapses it, so an EnKF's process noise is only ever raised.
        self.qscales = {g: QScale(min_base=1.0 if cfg.filter == "enkf" else 1e-3) for g in GROUPS}
        self._last_update: dict[str, float] = {}
        self._groups_of = {kind: [self.qscales[g] for g, (kinds, _) in GROUPS.items() if kind in kinds]
                           for kind in {k for kinds, _ in GROUPS.values() for k in kinds}}
        #: The last Q made, and what it was made of (a rate gyro heard, the groups'
        #: scales): the scales move only with the updates that adapt them.
        self._made: tuple[tuple[bool, tuple[float, ...]], np.ndarray] | None = None

    def Q(self, t: float | None) -> np.ndarray:
        """The density to predict with at filter time t (read-only: the same array until
        the scales change)."""
        gyro = t is not None and t - self._last_update.get("yaw_rate", -math.inf) <= DRIVER_SPAN
        key = (gyro, tuple(q.scale for q in self.qscales.values()))
        made = self._made
        if made is None or made[0] != key:
            Q = self._Q(gyro)
            if Q is not self.Qc:
                Q.flags.writeable = False
            self._made = made = (key, Q)
        return made[1]

    def _Q(self, gyro: bool) -> np.ndarray:
        """Qc with the groups' scales (`Q`)."""
        if self._gyro_states is None or gyro:
            if all(q.scale == 1.0 for q in self.qscales.values()):
                return self.Qc
            # With a rate gyro the yaw group scales the yaw acceleration's noise (r's
            # own stays the configured floor).
            groups = self._gyro_states or self.group_states
            Q = self.Qc.copy()
        else:
            # Without one, there is no yaw acceleration (its noise is 0) and the group
            # scales r's: ṙ would be a second difference of compass readings, 1 Hz of
            # them aliasing a seaway's wave yaw (a yacht's heading went from 2.3 to
            # 3.7 × her compass's error, Aava's gated headings from 22 to 31).
            groups = self.group_states
            Q = self.Qc.copy()
            i = self.yaw_index
            Q[i, i] = 0.0
        for g, states in groups.items():
            for i in states:
                Q[i, i] *= self.qscales[g].scale
        if groups is self._gyro_states:
            # r's own noise follows the yaw group down, never up: a calm ship's gyro
            # reading 0.005 °/s is then followed as closely as the paper's filter does
            # (Williamson: yaw-rate NIS 0.25 per dof with it fixed, 1.02 so), and a
            # seaway's yaw is the yaw acceleration's to carry
            Q[R, R] *= min(self.qscales["yaw"].scale, 1.0)
        return Q

    def groups_of(self, kind: str) -> list[QScale]:
        """The groups `kind` may drive."""
        return self._groups_of.get(kind, [])

    def driven_by(self, kind: str, t: float) -> list[QScale]:
        """The groups whose preferred sensor, of those heard in the last DRIVER_SPAN s,
        is `kind` (`GROUPS`); `kind` counts as heard at t from now on."""
        self._last_update[kind] = t
        out = []
        for g, (kinds, _) in GROUPS.items():
            for k in kinds:
                if t - self._last_update.get(k, -math.inf) <= DRIVER_SPAN:
                    if k == kind:
                        out.append(self.qscales[g])
                    break
        return out

    def reset(self) -> None:
        """The filter starts again: its scales are its own."""
        for q in self.qscales.values():
            q.reset()

    def scales(self) -> dict[str, float]:
        return {g: round(q.scale, 3) for g, q in self.qscales.items()}
