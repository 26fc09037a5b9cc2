"""The `manoeuvre` estimator plugin (entry point `edged.estimators: manoeuvre`)."""

from __future__ import annotations

from typing import Any, ClassVar

from edged.plugin import EstimatorPlugin

from .config import ManoeuvreConfig
from .core import ManoeuvreCore


class ManoeuvreEstimator(EstimatorPlugin):
    Config = ManoeuvreConfig
    Core = ManoeuvreCore
    kind: ClassVar[str | None] = "manoeuvre"
    description: ClassVar[str] = (
        "manoeuvring state u, v, r, heading, accelerations, drift and prediction: CTRA/CMM with EKF/UKF/EnKF "
        "(seeds 002, 001, 004)"
    )

    def status(self) -> dict[str, Any]:
        c = self.config
        # not "filter": the worker host puts the core's own health() there
        return {"mode": c.mode, "model": c.model, "kalman": c.filter}
