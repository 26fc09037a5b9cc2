"""The one door through which this plugin's measurements leave: validated and counted."""

from __future__ import annotations

from typing import Any

from edged.health import ComponentHealth
from edged.records import InvalidMeasurement, Measurement, validate_measurement


class Emitter:
    """Validates against edged.records (DESIGN §8: reject what cannot be true) and counts
    `measurements.<kind>` or `rejected.invalid_value`, so that every decoder path of
    the plugin rejects the same things the same way."""

    __slots__ = ("_health",)

    def __init__(self, health: ComponentHealth) -> None:
        self._health = health

    def __call__(
        self,
        out: list[Measurement],
        kind: str,
        source: str,
        t: float,
        values: dict[str, Any],
        t_src: float | None = None,
    ) -> None:
        try:
            validate_measurement(kind, values)
        except InvalidMeasurement as exc:
            self._health.count("rejected.invalid_value")
            self._health.error(f"{source}: {exc}")
            return
        self._health.count("measurements." + kind)
        out.append(Measurement(kind, source, t, values, t_src))

    def unavailable(self, what: str) -> None:
        """A sensor said "data not available": no measurement, but visible in health."""
        self._health.count("unavailable." + what)
