"""The fixed-width table `edged score` prints: one line per field, its sensors
indented under it."""

from __future__ import annotations

from .figures import LAGS, SIGMAS
from .scoring import Row

__all__ = ["render"]


def _g(x: float | None) -> str:
    return "-" if x is None else f"{x:.4g}"


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{x:.1f}"


def _ac(x: float | None) -> str:
    return "-" if x is None else f"{x:+.2f}"


#: Column headers; ASCII so that a terminal or pipe of any encoding shows them.
_HEAD = ("estimate", "field", "unit", "n", "rmse", "bias", "max", *(f"{k}sig%" for k in SIGMAS), *(f"ac{k}" for k in LAGS))


def render(rows: list[Row]) -> str:
    """The table: one line per field, its sensors indented under it."""
    cells: list[tuple[str, ...]] = []
    for r in rows:
        f = r.figures
        if r.baseline is None:
            first, second = r.estimate, r.field
        else:
            first, second = "", f"  vs {r.baseline} ({r.baseline_field})"
        cells.append(
            (first, second, r.unit, str(f.n), _g(f.rmse), _g(f.bias), _g(f.max_abs), *map(_pct, f.within), *map(_ac, f.ac))
        )
    widths = [max(len(h), *(len(c[i]) for c in cells)) for i, h in enumerate(_HEAD)]
    left = 3  # estimate, field, unit: text, left-aligned; figures right-aligned

    def line(c: tuple[str, ...]) -> str:
        return "  ".join(v.ljust(w) if i < left else v.rjust(w) for i, (v, w) in enumerate(zip(c, widths))).rstrip()

    return "\n".join([line(_HEAD), *map(line, cells)]) + "\n"
