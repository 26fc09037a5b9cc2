"""The Kalman equations of `edged_stw.kalman` (issue 34): what the STW filters compute
with them, and what importing the estimator costs.

The filters moved from filterpy's `predict`/`update` to these functions without changing
an estimate, so each is held here to filterpy's result *bit for bit* on random filters
of the sizes the package uses (the same numpy and LAPACK operations in the same order;
H·P of a 0/1 H and the products of a scalar update are exact). filterpy stays a test's
reference only: importing it (and through it scipy) cost every `edged replay` 0.6 s.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from edged_stw import ground, kalman
from edged_stw.ground import DriftWatch

fp_kalman = pytest.importorskip("filterpy.kalman")
fp_common = pytest.importorskip("filterpy.common")


def _filter(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A state and a positive definite covariance, its scale varied over decades."""
    A = rng.normal(size=(n, n))
    return rng.normal(size=n) * 10.0, A @ A.T * 10.0 ** rng.uniform(-4.0, 2.0)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(a, b)


def test_importing_the_estimator_imports_neither_filterpy_nor_scipy():
    """`edged replay` imports the core class at start-up: filterpy.kalman's package
    init imports scipy.stats, 0.6 s before the first record."""
    code = ("import sys, edged_stw.core, edged_stw.plugin; "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'filterpy', 'scipy'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


def test_predict_and_the_general_update_are_filterpys():
    rng = np.random.default_rng(1)
    for n, m in ((4, 2), (4, 3), (6, 1), (6, 2)):
        for _ in range(200):
            x, P = _filter(rng, n)
            F = np.eye(n) + rng.normal(size=(n, n)) * 0.1
            Q = np.diag(rng.uniform(0.0, 1e-3, n))
            u, B = rng.normal(), rng.normal(size=n)
            want = fp_kalman.predict(x, P, F, Q, u=u, B=B)
            got = kalman.predict(x, P, F, Q, B * u)
            assert _same(want[0], got[0]) and _same(want[1], got[1])
            H = rng.normal(size=(m, n))
            R = np.diag(rng.uniform(0.01, 1.0, m))
            z = H @ x + rng.normal(size=m)
            y, S, nis = kalman.innovation(x, P, z, R, H)
            assert nis == float((z - H @ x) @ np.linalg.solve(H @ P @ H.T + R, z - H @ x))
            want = fp_kalman.update(x, P, z, R, H)
            got = kalman.update(x, P, y, S, R, H)
            assert _same(want[0], got[0]) and _same(want[1], got[1])


def test_the_update_of_directly_measured_states_is_filterpys():
    """H = rows of the identity (GNSS position and velocity, a forecast's current)."""
    rng = np.random.default_rng(2)
    for rows in (slice(0, 2), slice(2, 4), slice(4, 6)):
        H = np.eye(6)[rows]
        for _ in range(300):
            x, P = _filter(rng, 6)
            R = np.eye(2) * rng.uniform(0.001, 10.0)
            z = x[rows] + rng.normal(size=2)
            y, S, nis = kalman.innovation_rows(x, P, z, R, rows)
            assert nis == kalman.innovation(x, P, z, R, H)[2]
            want = fp_kalman.update(x, P, z, R, H)
            got = kalman.update_rows(x, P, y, S, R, rows)
            assert _same(want[0], got[0]) and _same(want[1], got[1])


def test_the_scalar_update_is_filterpys():
    """One measurement (the log's reading, a speed-keeping pseudo-measurement)."""
    rng = np.random.default_rng(3)
    for _ in range(500):
        x, P = _filter(rng, 6)
        h = rng.normal(size=6)
        r = rng.uniform(1e-6, 1.0)
        z = float(h @ x) + rng.normal()
        y, s, nis = kalman.innovation_scalar(x, P, z, r, h)
        assert nis == kalman.innovation(x, P, np.array([z]), np.array([[r]]), h[None, :])[2]
        want = fp_kalman.update(x, P, np.array([z]), np.array([[r]]), h[None, :])
        got = kalman.update_scalar(x, P, y, s, r, h)
        assert _same(want[0], got[0]) and _same(want[1], got[1])


@pytest.mark.parametrize("T", [0.02, 0.1, 1.0, 1.0 / 3.0, 30.0, 1234.5])
def test_the_white_noise_q_is_filterpys(T):
    for order in (2, 3):
        assert _same(kalman.white_noise_q(order, T), fp_common.Q_continuous_white_noise(order, T))
    for q in (1e-9, 3.3e-5, 1e-2):
        want = fp_common.Q_continuous_white_noise(dim=3, dt=T, spectral_density=q, block_size=2, order_by_dim=False)
        assert _same(ground.process_noise(T, q), want)


def test_the_drift_watch_whitens_as_a_cholesky_factor_does():
    """The watch's 2×2 algebra written out against LAPACK's factor: the whitened mean
    agrees to rounding, the innovations' mean exactly, and no verdict differs."""
    rng = np.random.default_rng(4)
    for _ in range(50):
        watch, m, ybar, V, t0 = DriftWatch(), np.zeros(2), np.zeros(2), 0.0, None
        lean = rng.uniform(0.0, 0.1)
        for k in range(100):
            t = 0.1 * k
            A = rng.normal(size=(2, 2))
            S = A @ A.T * 0.2 + np.eye(2) * 0.05  # conditioned like P_v + R of the filter
            y = rng.multivariate_normal([lean, -lean], S)
            w = np.linalg.solve(np.linalg.cholesky(S), y)
            a = 1.0 if t0 is None else min(max(t - t0, 1e-3) / watch.tau, 1.0)
            t0 = t
            m, ybar, V = (1.0 - a) * m + a * w, (1.0 - a) * ybar + a * y, (1.0 - a) ** 2 * V + a * a
            want = V <= ground.DRIFT_MAX_VAR and float(m @ m) > ground.DRIFT_GATE * V
            assert watch.lean(t, y, S) == want
            assert math.isclose(watch.m0, m[0], rel_tol=1e-11, abs_tol=1e-14)
            assert math.isclose(watch.m1, m[1], rel_tol=1e-11, abs_tol=1e-14)
            assert _same(watch.y, ybar)
            if want:
                watch.clear()
                m, ybar, V = np.zeros(2), np.zeros(2), 0.0
    assert not DriftWatch().lean(0.0, np.array([1.0, 1.0]), np.array([[1.0, 2.0], [2.0, 1.0]]))  # not positive
