"""Nested JSON to flat rows for tables (`edged export`): `{"a": {"b": 1}}` -> `a.b`.

Lists stay one cell (as JSON text): expanding them by index would give every row a
different set of columns, which is what a pandas-friendly table must not have.
"""

from __future__ import annotations

import json
from typing import Any

__all__ = ["flatten", "cell"]


def flatten(obj: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in obj.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and v:
            out.update(flatten(v, key + "."))
        elif isinstance(v, dict):
            out[key] = None
        elif isinstance(v, list):
            out[key] = json.dumps(v, separators=(",", ":"))
        else:
            out[key] = v
    return out


def cell(v: Any) -> Any:
    """A value as a CSV cell: empty for null, `repr` precision for floats."""
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return v
