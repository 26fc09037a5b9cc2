"""The Doppler/EM log beside the STW estimate: read, fitted, published or not, warned of.

The log never moves the estimate (seed 000): each reading is kept to be published as
`dvl_stw`, fitted against the estimate to learn the log's own offset and scale (the
fit lives in the filter models, `dvl.LogCalibration`), watched for a dead or fouled
transducer (`watch.LogWatch`), and its error is published only once it is observable,
with a warning when it exceeds the configured tolerance.
"""

from __future__ import annotations

import logging
from typing import Any

from edged.estimator import Estimator

from .paper import PaperModel
from .vector import DVL_GATE, VectorModel
from .watch import LogWatch

log = logging.getLogger("edged.stw")

#: A log reading older than this (s) is not published as `dvl_stw`.
DVL_MAX_AGE = 10.0


class LogCheck:
    """The log's reading, fit verdicts, publication and warnings, for one core (whose
    `rejected` and innovation statistics it counts in)."""

    def __init__(self, cfg: Any, counts: Estimator) -> None:
        self.cfg = cfg
        self.counts = counts
        self.watch = LogWatch(cfg.min_speed)
        self.reading: tuple[float, float] | None = None  # t, stw_long
        self.reason: str | None = "no estimate yet"  # why dvl_bias is null (None: published)
        self.warnings: list[str] = []

    def fit(self, t: float, z: float, model: VectorModel | PaperModel, heading: float | None, turning: bool,
            forecast_seen: bool, est: dict[str, Any] | None) -> bool | None:
        """One log reading into the fit of its offset; returns whether the gate
        rejected it (None: not tried, and why is counted)."""
        rejected = self.counts.rejected
        if turning:
            rejected["water_speed.turning"] += 1
            return None
        if not forecast_seen:
            # Without a forecast the log's offset and the current along the ship are one
            # unknown (dvl − SOG = b − c·x̂): nothing to fit yet.
            rejected["water_speed.no_current"] += 1
            return None
        if est is None:
            rejected["water_speed.unconverged"] += 1
            return None
        if est["stw"] < self.cfg.min_speed:
            rejected["water_speed.slow"] += 1
            return None
        dry = self.watch.left_out
        if isinstance(model, PaperModel):
            nis, used = model.dvl(t, z, DVL_GATE, dry=dry)
        else:
            nis, used = model.dvl(t, z, heading, dry=dry)
        if nis is None:
            return None
        if dry:
            rejected["water_speed.left_out"] += 1
            return not used
        if used:
            self.counts.updated("water_speed", nis, 1)
        else:
            self.counts.gated("water_speed")
        return not used

    def publish(self, t: float, values: dict[str, Any], forecast_seen: bool) -> None:
        """The log's fields of an estimate: its latest reading, and its error once it
        is observable (null, and `reason` says why, until then)."""
        dvl = self.reading
        values["dvl_stw"] = dvl[1] if dvl is not None and t - dvl[0] <= DVL_MAX_AGE else None
        values.setdefault("dvl_bias", None)
        values.setdefault("dvl_scale", None)
        values.setdefault("dvl_std", None)
        self.reason = self._observable(values, forecast_seen)
        if self.reason is not None:
            values["dvl_bias"] = values["dvl_scale"] = values["dvl_std"] = None

    def _observable(self, v: dict[str, Any], forecast_seen: bool) -> str | None:
        """Why `dvl_bias` is null, or None when it is published."""
        if not self.counts.seen.get("water_speed"):
            return "no Doppler/EM log reading"
        if self.watch.left_out:
            return str(self.watch.problem)
        if not forecast_seen:
            return ("no current forecast: the log's offset and the current along the ship are one unknown "
                    "(dvl − SOG = b − current along), so the offset is not observable")
        std = v.get("dvl_std")
        if std is None:
            return "not fitted yet (the STW estimate is not converged, or the vessel is turning or slow)"
        if not std["bias"] <= self.cfg.dvl_observable_std:
            return (f"offset σ {std['bias']:.2f} m/s above dvl_observable_std {self.cfg.dvl_observable_std:.2f}: "
                    "not observable yet")
        return None

    def warn(self, v: dict[str, Any]) -> None:
        """Warn (in health, and in the log once per change) when the log is off: when
        its offset (or scale) exceeds the tolerance with 95 % confidence; the warning
        clears only below 80 % of the tolerance, so that a value near it does not
        make the warning come and go."""
        std = v.get("dvl_std")
        warnings: list[str] = []
        if std is not None:
            b = v["dvl_bias"]
            was = {w.split()[2] for w in self.warnings}
            keep = 0.8 if "reads" in was else 1.0
            if abs(b) - 1.96 * std["bias"] > keep * self.cfg.dvl_tolerance:
                warnings.append(
                    f"Doppler log reads {abs(b):.2f} m/s {'high' if b > 0 else 'low'} "
                    f"(±{std['bias']:.2f}, tolerance {self.cfg.dvl_tolerance:.2f})"
                )
            if v["dvl_scale"] is not None and std["scale"] is not None:
                k = v["dvl_scale"] - 1.0
                keep = 0.8 if "scale" in was else 1.0
                if abs(k) - 1.96 * std["scale"] > keep * self.cfg.dvl_scale_tolerance:
                    warnings.append(
                        f"Doppler log scale is {100 * k:+.1f} % (±{100 * std['scale']:.1f} %, "
                        f"tolerance {100 * self.cfg.dvl_scale_tolerance:.1f} %)"
                    )
        if {w.split()[2] for w in warnings} != {w.split()[2] for w in self.warnings}:
            for w in warnings:
                log.warning("stw: %s", w)
        self.warnings = warnings

    def details(self) -> dict[str, Any]:
        """The log's part of the core's health."""
        return {"warnings": list(self.warnings), "dvl": {"published": self.reason is None, "reason": self.reason}}
