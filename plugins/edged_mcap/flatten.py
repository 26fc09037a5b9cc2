"""Nested JSON to flat rows for tables (`edged export`): `{"a": {"b": 1}}` -> `a.b`.

Lists stay one cell (as JSON text): expanding them by index would give every row a
different set of columns, which is what a pandas-friendly table must not have.
"""

from __future__ import annotations

import json
from typing import Any

__all__ = ["flatten", "cell"]


def flatten(obj: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """`obj` with nested objects' keys joined by dots, in the order a depth-first walk
    meets them. Walked with a stack, not recursion: a payload of a foreign or damaged
    file may nest as deep as the JSON parser allows, deeper than Python's call stack."""
    out: dict[str, Any] = {}
    stack = [(prefix, iter(obj.items()))]
    while stack:
        pre, items = stack[-1]
        for k, v in items:
            key = f"{pre}{k}"
            if isinstance(v, dict) and v:
                stack.append((key + ".", iter(v.items())))
                break
            if isinstance(v, dict):
                out[key] = None
            elif isinstance(v, list):
                out[key] = _list_cell(v)
            else:
                out[key] = v
        else:
            stack.pop()
    return out


def _list_cell(v: list[Any]) -> str:
    try:
        return json.dumps(v, separators=(",", ":"))
    except RecursionError:  # parsed near the parser's depth limit, too deep to write again
        return "[nested too deep]"


def cell(v: Any) -> Any:
    """A value as a CSV cell: empty for null, `repr` precision for floats."""
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return v
