"""The two kinematic models against their equations: Jacobians against numerical
derivatives, Runge–Kutta against the closed-form turn, the accelerometer rows against
eqs. (8)–(12) of seed 002, angle handling."""

from __future__ import annotations

import math

import numpy as np
import pytest

from edged_manoeuvre.cmm import Cmm
from edged_manoeuvre.ctra import Ctra
from edged.angles import wrap_2pi, wrap_pi
from edged_manoeuvre.model import KINDS, circular_mean, rcond, residual, rk4, transition

MODELS = [Ctra(False), Ctra(True), Cmm(False), Cmm(True)]


def _state(model, rng) -> np.ndarray:
    x = rng.normal(0, 1, model.n)
    x[2:4] = (5.0 + rng.random(), 0.4 * rng.random() - 0.2)  # moving: CMM's |V| well above its floor
    x[4] = rng.random() * 2 * math.pi
    x[5] = 0.02 * rng.normal()
    x[6:8] = 0.05 * rng.normal(size=2)
    return x


def _numeric(fun, x, h=1e-6):
    f0 = fun(x)
    J = np.zeros((len(f0), len(x)))
    for j in range(len(x)):
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        J[:, j] = (fun(xp) - fun(xm)) / (2 * h)
    return J


@pytest.mark.parametrize("model", MODELS, ids=lambda m: f"{m.name}{'+bias' if m.bias else ''}")
def test_jacobians_are_the_derivatives_of_f_and_h(model):
    rng = np.random.default_rng(1)
    for _ in range(20):
        x = _state(model, rng)
        np.testing.assert_allclose(model.F(x), _numeric(model.f, x), atol=1e-7)
        for kind in KINDS:
            np.testing.assert_allclose(model.H(kind, x), _numeric(lambda s: model.h(kind, s), x), atol=1e-7,
                                       err_msg=kind)


@pytest.mark.parametrize("model", MODELS, ids=lambda m: f"{m.name}{'+bias' if m.bias else ''}")
def test_f_and_h_work_on_an_ensemble_as_on_each_member(model):
    rng = np.random.default_rng(2)
    X = np.array([_state(model, rng) for _ in range(7)])
    np.testing.assert_allclose(model.f(X), np.array([model.f(x) for x in X]), atol=1e-12)
    for kind in KINDS:
        np.testing.assert_allclose(model.h(kind, X), np.array([model.h(kind, x) for x in X]), atol=1e-12)


def test_ctra_turn_follows_the_circle():
    """u = 5 m/s, v = 0, r = 0.05 rad/s: a circle of radius u/r, closed form."""
    m = Ctra()
    x = m.from_motion(0.0, 0.0, 5.0, 0.0, 0.0, 0.05)
    out = rk4(m.f, x, 60.0, 0.05)
    psi = 0.05 * 60.0
    R = 5.0 / 0.05
    assert out[0] == pytest.approx(R * math.sin(psi), abs=1e-6)
    assert out[1] == pytest.approx(R * (1 - math.cos(psi)), abs=1e-6)
    assert out[4] == pytest.approx(psi, abs=1e-12)


def test_cmm_turn_with_normal_acceleration_is_the_same_circle():
    """CMM: a_n = V²/R bends the course-speed vector round the same circle."""
    m = Cmm()
    x = m.from_motion(0.0, 0.0, 5.0, 0.0, 0.0, 0.05)
    x[7] = 5.0 * 0.05  # a_n = V·ω
    out = rk4(m.f, x, 60.0, 0.05)
    R = 100.0
    assert out[0] == pytest.approx(R * math.sin(3.0), abs=1e-5)
    assert out[1] == pytest.approx(R * (1 - math.cos(3.0)), abs=1e-5)
    assert math.hypot(out[2], out[3]) == pytest.approx(5.0, abs=1e-9)


def test_accelerometers_read_the_coriolis_terms_in_both_models():
    """Eqs. (11)-(12): a turning hull reads a_y = a_v + u r even at constant speed."""
    ct, cm = Ctra(), Cmm()
    u, v, psi, r = 6.0, 0.3, 1.0, 0.02
    x = ct.from_motion(0, 0, u * math.cos(psi) - v * math.sin(psi), u * math.sin(psi) + v * math.cos(psi), psi, r)
    np.testing.assert_allclose(ct.h("accel", x), [-v * r, u * r], atol=1e-12)
    # the same motion in the CMM: the velocity turns at r (a_n = |V| r, a_t = 0)
    xm = cm.from_motion(0, 0, x[2] * 0 + u * math.cos(psi) - v * math.sin(psi),
                        u * math.sin(psi) + v * math.cos(psi), psi, r)
    xm[7] = math.hypot(u, v) * r
    np.testing.assert_allclose(cm.h("accel", xm), [-v * r, u * r], atol=1e-12)
    np.testing.assert_allclose(cm.body(xm), [u, v, 0.0, 0.0], atol=1e-12)


def test_cmm_at_rest_stays_finite():
    m = Cmm()
    x = m.from_motion(0, 0, 0.0, 0.0, 1.0, 0.0)
    x[6] = 0.01
    assert np.all(np.isfinite(m.f(x))) and np.all(np.isfinite(m.F(x))) and np.all(np.isfinite(m.H("accel", x)))


def test_transition_matches_the_jacobian_of_the_integrated_state():
    """Φ is the derivative of the integrated state to second order in the sub-step:
    its error shrinks about 100-fold for a 10-fold smaller sub-step."""
    m = Ctra(True)
    x = _state(m, np.random.default_rng(3))
    num = _numeric(lambda s: rk4(m.f, s, 0.1, 0.05), x)
    x1, phi = transition(m.F, m.f, x, 0.1, 0.05)
    np.testing.assert_allclose(x1, rk4(m.f, x, 0.1, 0.05), atol=1e-12)
    coarse = np.abs(phi - num).max()
    fine = np.abs(transition(m.F, m.f, x, 0.1, 0.005)[1] - _numeric(lambda s: rk4(m.f, s, 0.1, 0.005), x)).max()
    assert coarse < 1e-5 and fine < coarse / 50  # second order: 100-fold, less the numerics


def test_angles_wrap_where_the_contract_says():
    assert wrap_pi(math.pi) == pytest.approx(math.pi) and wrap_pi(-math.pi) == pytest.approx(math.pi)
    assert wrap_pi(2 * math.pi - 0.1) == pytest.approx(-0.1)
    assert wrap_2pi(-1e-17) == 0.0 and 0.0 <= wrap_2pi(-0.1) < 2 * math.pi
    # a heading residual across north is small, never ±2π
    y = residual(KINDS["heading"], np.array([0.01]), np.array([2 * math.pi - 0.01]))
    assert y[0] == pytest.approx(0.02)
    assert circular_mean(np.array([2 * math.pi - 0.01, 0.01])) == pytest.approx(0.0, abs=1e-12)
    # weighted, as unscented weights are (one negative)
    w = np.array([-0.5, 0.75, 0.75])
    assert circular_mean(np.array([0.0, 0.1, -0.1 % (2 * math.pi)]), w) == pytest.approx(0.0, abs=1e-12)


def test_rcond_is_eq_23():
    rng = np.random.default_rng(4)
    for n in (1, 2, 3):
        for _ in range(10):
            A = rng.normal(size=(n, n))
            S = A @ A.T + 0.1 * np.eye(n)
            assert rcond(S) == pytest.approx(1.0 / (np.linalg.norm(S, 1) * np.linalg.norm(np.linalg.inv(S), 1)))
    assert rcond(np.array([[1.0, 1.0], [1.0, 1.0]])) == 0.0
    assert rcond(np.array([[np.nan]])) == 0.0
