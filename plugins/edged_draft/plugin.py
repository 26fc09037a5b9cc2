"""The `draft` estimator plugin (entry point `edged.estimators: draft`; its estimate's
fields: `edged.estimate_kinds: draft`, `estimate.py`)."""

from __future__ import annotations

from typing import Any, ClassVar

from edged.plugin import EstimatorPlugin

from .config import DraftConfig
from .core import DraftCore


class DraftEstimator(EstimatorPlugin):
    Config = DraftConfig
    Core = DraftCore
    kind: ClassVar[str | None] = "draft"
    description: ClassVar[str] = (
        "draft at six marks with the waves separated from the mean; trim, list, deflection, squat, "
        "under-keel clearance and cargo (seed 003)"
    )

    def status(self) -> dict[str, Any]:
        return {"mode": self.config.mode}
