"""Nested JSON to one flat row: `{"a": {"b": 1}}` -> `{"a.b": 1}`.

In the core because two plugins that must not import each other need it: the
recorder's `edged export` (a topic as a table) and `edged plot` (a field by its dotted
path). It knows no format and no sensor: a payload is any JSON object.

Lists stay one value (as JSON text): expanding them by index would give every row a
different set of columns, which is what a pandas-friendly table must not have.
"""

from __future__ import annotations

import json
from typing import Any

__all__ = ["flatten"]


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
