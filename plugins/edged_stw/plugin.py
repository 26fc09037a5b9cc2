"""The `stw` estimator plugin (entry point `edged.estimators: stw`; its estimate's
fields: `edged.estimate_kinds: stw`, `estimate.py`)."""

from __future__ import annotations

from typing import Any, ClassVar

from edged.plugin import EstimatorPlugin

from .config import StwConfig
from .core import StwCore


class StwEstimator(EstimatorPlugin):
    Config = StwConfig
    Core = StwCore
    kind: ClassVar[str | None] = "stw"
    description: ClassVar[str] = "speed through water from GNSS, IMU and current forecasts (seed 000); the Doppler log only checked"

    def status(self) -> dict[str, Any]:
        return {"mode": self.config.mode}
