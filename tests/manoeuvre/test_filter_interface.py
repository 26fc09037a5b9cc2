"""The three filters declare the one interface the core drives them through
(`edged_manoeuvre.filter.KalmanFilter`), and each implements all of it itself."""

from __future__ import annotations

import numpy as np
import pytest

from edged_manoeuvre.config import ManoeuvreConfig
from edged_manoeuvre.ctra import Ctra
from edged_manoeuvre.ekf import Ekf
from edged_manoeuvre.enkf import Enkf
from edged_manoeuvre.filter import KalmanFilter
from edged_manoeuvre.start import make_filter
from edged_manoeuvre.ukf import Ukf

METHODS = ("predict", "update", "shift", "reset_position", "ensemble_size")
FILTERS = {"ekf": Ekf, "ukf": Ukf, "enkf": Enkf}


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_each_filter_declares_and_implements_the_interface(name):
    cls = FILTERS[name]
    assert KalmanFilter in cls.__mro__ and cls.name == name  # declared, not only shaped alike
    for method in METHODS:  # its own, not the protocol's empty body
        assert getattr(cls, method) is not getattr(KalmanFilter, method), method


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_the_configured_filter_runs_through_the_interface(name):
    model = Ctra(False, 2.0)
    x0 = np.zeros(model.n)
    x0[2] = 5.0  # 5 m/s ahead, heading north
    P0 = np.eye(model.n) * 0.01
    f = make_filter(ManoeuvreConfig(type="manoeuvre", filter=name, members=20), model, x0, P0)
    assert isinstance(f, FILTERS[name]) and isinstance(f, KalmanFilter)
    f.predict(1.0, np.eye(model.n) * 1e-4)
    inn = f.update("position", np.array([5.0, 0.0]), np.eye(2))
    assert inn.applied and inn.nis >= 0.0
    assert f.x.shape == (model.n,) and f.P.shape == (model.n, model.n)
    assert f.x[0] == pytest.approx(5.0, abs=1.0)
    f.shift(5.0, 0.0)
    assert f.x[0] == pytest.approx(0.0, abs=1.0)
    f.reset_position(np.array([100.0, 0.0]), np.eye(2))
    assert f.x[0] == pytest.approx(100.0, abs=10.0)
    assert f.ensemble_size() == (20 if name == "enkf" else 0)
