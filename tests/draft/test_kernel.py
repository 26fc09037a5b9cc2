"""The compiled predict and update (kernel.py) are the numpy stacked step's equations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from edged_draft import waves
from edged_draft.bank import WaveBank
from edged_draft.waves import WaveMark, step_marks

# numba comes with the `fast` extra, which `make test` installs: one that will not
# import is a failure to see, not a skip.
import numba  # noqa: E402,F401


def run(monkeypatch: pytest.MonkeyPatch, compiled: bool) -> tuple[WaveBank, list[WaveMark], list, int]:
    """Six marks at 100 Hz over 20 s: a sea of two periods, the speed ramping (the squat
    term), a jump at step 700 the gate stops, the bank retuned every second."""
    calls = 0
    real = waves._step_compiled

    def counted(*args):
        nonlocal calls
        calls += 1
        return real(*args)

    monkeypatch.setattr(waves, "_step_compiled", counted)
    if not compiled:
        monkeypatch.setattr(waves, "_KERNEL", None)
    rng = np.random.default_rng(11)
    bank = WaveBank(3.0, 25.0, 12, 0.006, 1e-11, 1e-7)
    marks = [WaveMark(bank, 10.0 + 0.1 * i, 0.0, 0.1, 0.05, squat=(0.01, 0.02)) for i in range(6)]
    out = []
    for k in range(1, 2000):
        t = 0.01 * k
        zs = [10.0 + 0.1 * i + 0.3 * math.sin(0.6 * t + i) + 0.1 * math.sin(0.35 * t) + rng.normal(0.0, 0.1)
              + (2.0 if 700 <= k < 703 else 0.0) for i in range(6)]
        u = (3.0 + 0.002 * k) ** 2 if k > 300 else None
        out.append(step_marks(marks, [t] * 6, zs, [0.01 + 0.001 * i for i in range(6)], [(u, 0.1)] * 6, 15.1))
        if k % 100 == 0:
            bank.retune(0.05)
    monkeypatch.undo()
    return bank, marks, out, calls


def test_the_compiled_step_agrees_with_numpy(monkeypatch):
    bank_c, marks_c, out_c, calls_c = run(monkeypatch, compiled=True)
    bank_n, marks_n, out_n, calls_n = run(monkeypatch, compiled=False)
    assert calls_c == 1999 and calls_n == 0  # every step compiled in one run, none in the other
    gated = 0
    for (yc, Sc, nc, ac), (yn, Sn, nn, an) in zip(out_c, out_n):
        assert np.allclose(yc, yn, rtol=0, atol=1e-10) and np.allclose(Sc, Sn, rtol=1e-12)
        assert (ac == an).all()
        gated += int((~ac).sum())
    assert gated >= 6  # the jump was stopped, alike
    assert np.allclose(bank_c.X, bank_n.X, rtol=0, atol=1e-10)
    assert np.allclose(bank_c.P, bank_n.P, rtol=0, atol=1e-13)
    assert np.allclose(bank_c.var_k, bank_n.var_k, rtol=0, atol=1e-13)
    assert np.allclose(bank_c.prev_c, bank_n.prev_c, rtol=0, atol=1e-10)
    assert np.array_equal(bank_c.prev_t, bank_n.prev_t)
    assert np.allclose(bank_c.omega, bank_n.omega, rtol=1e-12)
    assert not np.allclose(bank_c.omega, bank_c.omega0)  # the phase observation moved ω
    assert [m.u for m in marks_c] == [m.u for m in marks_n] and [m.t for m in marks_c] == [m.t for m in marks_n]
