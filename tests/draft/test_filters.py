"""The per-mark filters of the draft estimator: the paper's (seed 003 eqs. 13–24, with
the discretisation fix) and the wave bank's, on seeded synthetic readings."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

from edged_draft.paper import PaperMark
from edged_draft.bank import WaveBank
from edged_draft.waves import WaveMark, step_marks


def _van_loan(A: np.ndarray, Qc: np.ndarray, dt: float) -> np.ndarray:
    n = len(A)
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n], M[:n, n:], M[n:, n:] = -A, Qc, A.T
    E = expm(M * dt)
    Phi = E[n:, n:].T
    return Phi @ E[:n, n:]


@pytest.mark.parametrize("t", [0.0, 7.3, 3600.0])
def test_the_papers_q_is_van_loans_over_the_step_whatever_the_hour(t):
    """Eq. (23) over the step itself: the same Q an hour in as at the start (eq. 24 as
    printed grows with t²), and A(dt) = I + A·dt exactly."""
    f = PaperMark(10.0, 0.0, 2 * math.pi / 12, 0.4, 1e-3, 1e-3, 0.1)
    f.t = t
    P0 = f.P.copy()
    dt = (t + 0.01) - t  # as the filter will see it
    c = f.omega * math.cos(f._phase(t))
    A = np.array([[0.0, 1.0, c], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    f.predict(t + dt)
    Phi = expm(A * dt)
    assert np.allclose(Phi, [[1, dt, c * dt], [0, 1, 0], [0, 0, 1]])
    Q = f.P - Phi @ P0 @ Phi.T
    assert np.allclose(Q, _van_loan(A, np.diag([0.0, 1e-3, 1e-3]), dt), rtol=1e-9, atol=1e-15)
    assert Q[0, 0] < 1e-8


def _regular(duration: float = 600.0, seed: int = 3, period: float = 12.0, ramp: float = 0.0):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 0.01)
    mean = 10.0 + ramp * t
    wave = 0.4 * np.sin(2 * math.pi * t / period + 0.3)
    return t, mean, wave, mean + wave + rng.normal(0.0, 0.1, len(t))


def _filter(f, t, z, retune=None):
    d, m = np.zeros(len(t)), np.zeros(len(t))
    for i in range(len(t)):
        f.predict(t[i])
        f.update(z[i], 0.01, 15.1)
        if retune is not None and i % 100 == 99:
            retune.retune(0.05)
        d[i], m[i] = f.draft, f.mean
    return d, m


def test_the_paper_filter_with_the_right_omega_gives_the_wave_free_draft():
    t, mean, wave, z = _regular(300.0)
    f = PaperMark(z[0], 0.0, 2 * math.pi / 12, 0.3, 1e-3, 1e-3, 0.1)
    d, m = _filter(f, t, z)
    k = t > 60
    assert np.sqrt(np.mean((d - mean - wave)[k] ** 2)) < 0.1  # better than a reading (0.1 m)
    assert np.sqrt(np.mean((m - mean)[k] ** 2)) < 0.05


def test_the_wave_bank_finds_the_sea_and_separates_it_from_the_draft():
    """A 12-s sea of 0.4 m on a discharge of 2.4 mm/s, readings σ 0.1 m at 100 Hz: the
    bank tunes itself to 12 s, the mean is within a centimetre, the instantaneous
    draft five times better than a reading (one mark alone: the six together do
    better, `derived.rigid_waves`), the amplitude 0.4 m."""
    t, mean, wave, z = _regular(600.0, ramp=-0.0024)
    bank = WaveBank(3.0, 25.0, 12, 0.003, 1e-9)
    f = WaveMark(bank, z[0], 0.0, 0.1, 0.3)
    d, m = _filter(f, t, z, retune=bank)
    k = t > 120
    assert f.peak_period() == pytest.approx(12.0, rel=0.01)
    assert np.sqrt(np.mean((m - mean)[k] ** 2)) < 0.01
    assert np.sqrt(np.mean((d - mean - wave)[k] ** 2)) < 0.1 / 5
    assert f.amplitude == pytest.approx(0.4, rel=0.05)
    assert f.rate == pytest.approx(-0.0024, abs=0.001)  # an instant of it: the cargo rate needs minutes


def test_a_bank_without_retuning_is_worse_off_between_its_frequencies():
    """The same sea at 13.5 s, between two of the bank's resonators: left where they
    are, the two share it with a beat that the level takes up; moved to it, the mean
    is better by a third."""
    t, mean, wave, z = _regular(400.0, period=13.5)
    k = t > 120
    errs = []
    for retune in (False, True):
        bank = WaveBank(3.0, 25.0, 12, 0.003, 1e-9)
        _, m = _filter(WaveMark(bank, z[0], 0.0, 0.1, 0.3), t, z, retune=bank if retune else None)
        errs.append(np.sqrt(np.mean((m - mean)[k] ** 2)))
    assert errs[1] < 0.67 * errs[0]


def test_the_paper_filter_given_a_wrong_omega_leaves_the_sea_in_the_mean_the_bank_does_not():
    """The paper needs ω_e: told 10 s of a 12-s sea, its mean carries the waves; the
    bank, told nothing, finds them (ESTIMATORS.md §3: the default must not need ω_e)."""
    t, mean, wave, z = _regular(300.0)
    k = t > 120
    _, m_paper = _filter(PaperMark(z[0], 0.0, 2 * math.pi / 10, 0.3, 1e-3, 1e-3, 0.1), t, z)
    bank = WaveBank(3.0, 25.0, 12, 0.003, 1e-10)
    _, m_bank = _filter(WaveMark(bank, z[0], 0.0, 0.1, 0.3), t, z, retune=bank)
    paper = np.sqrt(np.mean((m_paper - mean)[k] ** 2))
    adaptive = np.sqrt(np.mean((m_bank - mean)[k] ** 2))
    print(f"mean draft RMSE, ω_e 20 % off: paper {paper * 100:.1f} cm, adaptive {adaptive * 100:.2f} cm")
    assert adaptive < paper / 10  # measured: 0.36 cm against 29.0


def test_marks_filtered_together_are_filtered_as_each_alone():
    """`step_marks` (the six marks' readings in one stacked step) is the same filter as
    `predict` + `update` per mark: on readings at shared and at staggered times, some
    marks silent at some steps, a jump the gate stops, the speed changing (the squat
    term) and the bank retuned, the states, covariances and ω agree to rounding."""
    rng = np.random.default_rng(5)
    banks, marks = [], []
    for _ in range(2):
        bank = WaveBank(3.0, 25.0, 12, 0.003, 1e-10, 1e-7)
        banks.append(bank)
        marks.append([WaveMark(bank, 10.0 + 0.1 * i, 0.0, 0.1, 0.05, squat=(0.01, 0.02)) for i in range(6)])
    alone, together = marks
    gated = 0
    for k in range(1, 1500):
        t = 0.01 * k
        who = [i for i in range(6) if k % 9 != i]  # one mark silent now and then
        ts = [t + (0.002 * i if k % 4 == 0 else 0.0) for i in who]  # staggered at times
        zs = [10.0 + 0.1 * i + 0.3 * math.sin(0.6 * t + i) + rng.normal(0.0, 0.1) + (2.0 if k == 700 else 0.0)
              for i in who]
        u = (3.0 + 0.002 * k) ** 2 if k > 300 else None
        got = step_marks([together[i] for i in who], ts, zs, [0.01] * len(who), [(u, 0.1)] * len(who), 15.1)
        for j, i in enumerate(who):
            alone[i].predict(ts[j], u, 0.1)
            y, S, nis, applied = alone[i].update(zs[j], 0.01, 15.1)
            assert got[0][j] == pytest.approx(y, abs=1e-9) and got[3][j] == applied
            gated += not applied
        if k % 100 == 0:
            for b in banks:
                b.retune(0.05)
    assert gated >= 5  # the jump at step 700 was stopped by the gate, alike in both
    for a, b in zip(alone, together):
        assert np.allclose(a.x, b.x, rtol=0, atol=1e-9)
        assert np.allclose(a.P, b.P, rtol=0, atol=1e-12)
        assert np.allclose(a.var_k, b.var_k, rtol=0, atol=1e-12)
        assert a.t == b.t and a.u == b.u
    assert np.allclose(banks[0].omega, banks[1].omega, rtol=1e-12)
    assert not np.allclose(banks[0].omega, banks[0].omega0)  # the retune was exercised
