"""One measurement through the filter: judged, averaged, predicted to, updated with,
and what its innovation says about the filter, the sensor and the process noise.

Each measurement is met at its own time: the filter is predicted from its last time
to the measurement's (any interval, Runge–Kutta sub-steps) and updated with that
sensor's rows of h only (seed 002 Table 2, split by sensor).

Monitoring (seed 002 §4): every update's NIS against its χ² band and rcond(S)
(eq. 23); rcond below 1e-10 is a divergence, and so is a state or covariance that is
not finite or a variance beyond any physical sense (`VAR_MAX`: a one-row S, as a
heading's, always has rcond 1): counted, reported, and the filter starts again from
the next measurements.

`UpdateSteps` is the half of `core.ManoeuvreCore` that does this; the core makes the
state it works on (`ManoeuvreCore.__init__`) and owns the starts and resets it calls.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import TYPE_CHECKING, Any

import numpy as np

from .adaptive import Gate, NoiseEstimate, Roughness
from .config import DEG
from .gnss_checks import GNSS_EPOCH
from .model import KINDS, R, Innovation, residual

if TYPE_CHECKING:
    from edged.geo import LocalPlane

    from .cmm import Cmm
    from .config import ManoeuvreConfig
    from .ctra import Ctra
    from .decimate import Decimator
    from .filter import KalmanFilter
    from .forecast import Forecast
    from .gnss_checks import GnssChecks
    from .process_noise import ProcessNoise
    from .start import Start
    from .wave_yaw import WaveYaw

#: rcond(S) below this is a diverged filter (seed 002 §4.2).
RCOND_MIN = 1e-10
#: Variances beyond these are a filter that has lost itself, whatever rcond says (a
#: one-row S always has rcond 1): positions (m²), velocities (m²/s²), heading (rad²).
VAR_MAX = {0: 1e10, 1: 1e10, 2: 1e4, 3: 1e4, 4: 1e2}
#: The smallest 1-σ a sensor's learned noise may reach (per row): below any real
#: sensor's, so that the estimate follows a good sensor but never trusts one blindly.
SIGMA_FLOOR = {
    "position": np.full(2, 0.05),
    "heading": np.array([0.005 * DEG]),
    "yaw_rate": np.array([0.0005 * DEG]),
    "accel": np.full(2, 0.001),
    "velocity": np.full(2, 0.005),
}
#: Sensors whose noise is white, so that their readings' own roughness bounds it
#: (`adaptive.Roughness`): rate gyros. Not a GNSS position (its error wanders over
#: seconds: bounded so, its R fell below the truth and its NIS rose to 2.4 per dof),
#: nor a compass (a gyrocompass's error is smooth).
ROUGH_KINDS = frozenset({"yaw_rate"})
#: Seconds without a fix after which a sample-at-a-time accelerometer's R takes in the
#: wave yaw (`_between_fixes`).
SPARSE_FIX = 3.0


class UpdateSteps:
    """The core's measurement pipeline (see the module's docstring). It calls the
    core's `_heard` (the sources' judgement), `_diverged`, `_start_again` and
    `_position_jump` (the resets), and works on this state of the core's:"""

    cfg: ManoeuvreConfig
    model: Ctra | Cmm
    filter: KalmanFilter | None
    t: float | None
    plane: LocalPlane | None
    process: ProcessNoise
    forecast: Forecast
    gnss: GnssChecks
    wave: WaveYaw
    start: Start
    decimator: Decimator
    sigma0: dict[str, np.ndarray]
    noise: dict[tuple[str, str], NoiseEstimate]
    roughness: dict[tuple[str, str], Roughness]
    gates: dict[tuple[str, str], Gate]
    rejected: Counter[str]
    resets: Counter[str]
    trace: list[tuple[float, str, float, int, bool, np.ndarray]] | None
    _since_start: Counter[str]
    _nis: float | None
    _rcond: float | None
    _raw_fix: tuple[float, float, float] | None
    _last_fix: dict[str, tuple[float, Any, Any, float | None]]

    def _measure(self, kind: str, t: float, z: np.ndarray, source: str) -> None:
        """One reading of `kind` (`model.KINDS`) from `source` at data time t."""
        if kind != "position" and not self._heard(kind, t, z, source):
            return
        f = self.filter
        if f is None or self.t is None:
            return
        top = self._rough(kind, t, z, source)
        block = self.decimator.push(kind, source, t, z, KINDS[kind].angle_rows)
        if block is None:
            return
        t, z, samples, scatter = block
        dt = t - self.t
        if dt < -0.5:
            self.rejected[f"{kind}.late"] += 1
            return
        if dt > self.cfg.reset_after:  # the filter's sensors were silent (only a current spoke)
            self.resets["gap"] += 1
            self.reset(f"no {'/'.join(KINDS)} for {dt:.0f} s", t)
            self._start_again()
            return
        key = (kind, source)
        noise = self._noise(key, scatter, top, samples)
        gate = self.gates.get(key)
        if gate is None:
            gate = self.gates[key] = Gate()
        if dt > 0.0:
            f.predict(dt, self.process.Q(self.t))
            self.t = t
        R_ = noise.R()
        if dt < 0.0:
            z, R_ = self._aligned(kind, z, R_, -dt)
        if kind == "position":
            if self._far(t, z, source):
                return
            if self.plane is not None:
                self.forecast.witness(t, self.plane, z, f.x, R_)
        limit = gate.limit(KINDS[kind].dim) if self.cfg.gate else None
        if kind == "accel" and samples <= 1 and self._between_fixes(t):
            R_ = self._slow_accel_R(R_)
        inn = f.update(kind, z, R_, limit)
        self._judge(kind, t, z, R_, source, inn, limit, gate, noise)

    def _rough(self, kind: str, t: float, z: np.ndarray, source: str) -> np.ndarray | None:
        """The raw readings' roughness, before they are averaged: a bound on a white
        sensor's noise variance (`ROUGH_KINDS`), or None."""
        if kind not in ROUGH_KINDS:
            return None
        rough = self.roughness.get((kind, source))
        if rough is None:
            rough = self.roughness[(kind, source)] = Roughness()
        return rough.add(t, z, lambda a, b: residual(KINDS[kind], a, b))

    def _noise(self, key: tuple[str, str], scatter: np.ndarray | None, top: np.ndarray | None,
               samples: int) -> NoiseEstimate:
        """The sensor's learned noise, primed by a block's scatter and bounded by its
        roughness (`top`, per reading: a mean of `samples` independent readings)."""
        kind = key[0]
        noise = self.noise.get(key)
        if noise is None:
            # An average of n readings has 1/n of one's variance only if they are
            # independent (a gateway's bursts of repeated readings are not): start from
            # one reading's and let the residuals bring it down.
            noise = self.noise[key] = NoiseEstimate(self.sigma0[kind] ** 2, SIGMA_FLOOR[kind])
        if self.cfg.adapt_r and self.cfg.filter != "enkf":
            # Not an ensemble's: perturbed observations far more precise than its spread
            # collapse it through the sampling error of a hundred members (the sway,
            # which no sensor sees, then drifts); its sensors start conservative.
            noise.prime(scatter)
            if top is not None:
                noise.ceiling(top / max(samples, 1))  # a mean of n independent readings
        return noise

    def _judge(self, kind: str, t: float, z: np.ndarray, R_: np.ndarray, source: str, inn: Innovation,
               limit: float | None, gate: Gate, noise: NoiseEstimate) -> None:
        """What an update's innovation says: a diverged filter, a gated measurement, or
        an applied one that the adaptation learns from."""
        f = self.filter
        dof = KINDS[kind].dim
        self._nis, self._rcond = inn.nis, inn.rcond
        if self.trace is not None:
            self.trace.append((t, kind, inn.nis, dof, inn.applied, _whiten(inn.y, inn.S)))
        if inn.rcond < RCOND_MIN:
            self._diverged(f"rcond(S) {inn.rcond:.2e} at a {kind} update")
            return
        why = _insane(f.x, f.P)
        if why:
            self._diverged(f"{why} after a {kind} update")
            return
        if not inn.applied:
            self._gated(kind, t, z, R_, source, inn, limit, gate)
            return
        adapt_q = self.cfg.adapt_q
        if gate.result(True):
            self.resets[f"{kind}.gate_released"] += 1
            if adapt_q:
                for q in self.process.driven_by(kind, t):
                    q.bump(10.0)
        self.updated(kind, inn.nis, dof)
        self._since_start[kind] += 1
        self.wave.add(t, float(f.x[R]))
        driven = self.process.driven_by(kind, t)
        if adapt_q:
            for q in driven:
                q.add(t, inn.nis, dof)
        if self.cfg.adapt_r and not any(q.raised for q in self.process.groups_of(kind)):
            noise.add(inn.y, inn.S, R_)  # a manoeuvre is not sensor noise

    def _gated(self, kind: str, t: float, z: np.ndarray, R_: np.ndarray, source: str, inn: Innovation,
               limit: float | None, gate: Gate) -> None:
        """A measurement its gate kept out."""
        dof = KINDS[kind].dim
        self.gated(kind)
        if self.cfg.adapt_q and limit is not None:
            # a gated measurement still says the model is off: counted, at most at
            # twice the gate, so that one outlier cannot move Q much
            for q in self.process.driven_by(kind, t):
                q.add(t, min(inn.nis, 2.0 * limit), dof)
        gate.result(False)
        if kind in ("position", "velocity") and self._gnss_gated_both(kind, t, source):
            return
        if kind == "position" and gate.in_row >= gate.run:
            self._position_jump(z, R_)

    def _aligned(self, kind: str, z: np.ndarray, R_: np.ndarray, lag: float) -> tuple[np.ndarray, np.ndarray]:
        """A measurement `lag` s older than the state, carried to the state's time:
        z + (∂h/∂x · f(x))·lag, its covariance raised by lag²·B P Bᵀ (B = ∂h/∂x · ∂f/∂x,
        what the rate's own error adds). An IMU block is stamped at its mean time, up to
        0.05 s behind the 10 Hz gyro that moved the filter on: a yacht's wave yaw
        changes r by 0.5 °/s in that time, 60 × a MEMS gyro's averaged noise, and such
        updates were 13 % of its NIS, gated or pulling r back."""
        m = self.model
        x = self.filter.x
        Hm = m.H(kind, x)
        rate = Hm @ m.f(x)
        B = Hm @ m.F(x)
        return z + rate * lag, R_ + lag * lag * (B @ self.filter.P @ B.T)

    def _between_fixes(self, t: float) -> bool:
        """No fix for SPARSE_FIX s: the accelerometers are what carries the motion.
        Where the GNSS speaks each second it holds u and v itself, and the wave yaw's
        R (`_slow_accel_R`) would only throw away the surge the IMU sees between fixes
        (yacht:coastal, GNSS at 1 Hz, IMU at 1 Hz: SOG 0.72 → 1.67 × the GNSS's)."""
        newest = max((f[0] for f in self._last_fix.values()), default=None)
        return newest is None or t - newest > SPARSE_FIX

    def _slow_accel_R(self, R_: np.ndarray) -> np.ndarray:
        """An accelerometer read one sample at a time (slower than `max_rate`): its R
        plus what the model cannot follow between samples. A hull yawing about a steady
        course (a yacht's wave yaw, r swinging by σ_r within seconds) has a sway
        acceleration that cancels u·r and a surge one that cancels −v·r; the model's
        accelerations are random walks, and a 1 Hz sample cannot tell them, so the
        Coriolis rows (eqs. 11–12) are off by about u·σ_r and v·σ_r. Taken as they were,
        a yacht's 1 Hz IMU took u from 2.6 to 1.2 m/s within ten seconds of each 30-s
        fix (u RMSE 1.96 m/s; without the IMU 0.32)."""
        u, v = (float(b) for b in self.model.body(self.filter.x)[0:2])
        add = np.array([v * v, u * u]) * self.wave.var
        return R_ + np.diag(add)

    def _far(self, t: float, z: np.ndarray, source: str) -> bool:
        """A fix too far from the estimate (`gnss_checks.GnssChecks.far`): held out, or,
        still there after the hold, taken as the position. True: not to be updated with."""
        f = self.filter
        verdict = self.gnss.far(t, z, source, f.x, f.P)
        if verdict == "held":
            self.rejected["position.far"] += 1
        elif verdict == "jump":
            f.reset_position(z, self.noise[("position", source)].R())
            self.resets["position_jump"] += 1
        return verdict != "near"

    def _gnss_gated_both(self, kind: str, t: float, source: str) -> bool:
        """A position and a velocity of one GNSS epoch both kept out by their gates: the
        vessel did what the filter did not expect (a yacht in a seaway between 30-s
        fixes lost her speed to 0 and stayed there, 28 SOG/COG gated in 30 minutes; a
        tanker's order to slow down). The filter starts again from this epoch's fix and
        SOG/COG (counted `diverged`). A fix that jumped alone leaves the velocity in its
        gate, and is held out as before."""
        if not self.gnss.one_epoch_gated(kind, t):
            return False
        fix = self._raw_fix
        self._diverged("a GNSS position and velocity of one epoch both beyond their gates: "
                       "a manoeuvre the filter missed")
        if fix is not None and self.plane is not None and abs(fix[0] - t) <= GNSS_EPOCH:
            pn, pe = self.plane.to_ne(fix[1], fix[2])
            if kind == "position":
                self.start.fixes_source = source
            self.start.fixes.append((fix[0], pn, pe))
        return True


def _insane(x: np.ndarray, P: np.ndarray) -> str | None:
    """Why a state or covariance is beyond any sense (`VAR_MAX`), or None. Read as
    floats: a dozen comparisons, where numpy's would cost more in calls."""
    for v in x.tolist():
        if not -math.inf < v < math.inf:  # NaN fails both
            return "a state that is not finite"
    d = P.diagonal().tolist()
    for v in d:
        if not -1e-9 <= v < math.inf:
            return "a covariance that is not finite or not positive"
    for i, top in VAR_MAX.items():
        if d[i] > top:
            return f"variance {d[i]:.3g} of state {i} beyond {top:g}"
    return None


def _whiten(y: np.ndarray, S: np.ndarray) -> np.ndarray:
    """L⁻¹ y with S = L Lᵀ: the innovation in units of its own σ."""
    try:
        return np.linalg.solve(np.linalg.cholesky(S), y)
    except np.linalg.LinAlgError:
        return np.full_like(y, np.nan)
