"""The `stw` estimator plugin (entry point `edged.estimators: stw`)."""

from __future__ import annotations

from typing import Any, ClassVar

from edged.plugin import EstimatorPlugin

from .config import StwConfig
from .core import StwCore


class StwEstimator(EstimatorPlugin):
    Config = StwConfig
    kind: ClassVar[str | None] = "stw"
    description: ClassVar[str] = "speed through water from GNSS, IMU and current forecasts (seed 000); the Doppler log only checked"

    def make_core(self) -> StwCore:
        return StwCore(self.config)

    def status(self) -> dict[str, Any]:
        return {"mode": self.config.mode}
