"""The configuration reference, made from the schemas themselves.

Every table of the configuration file is a pydantic model: the core's `[edged]` and
`[router]`, and each installed plugin's `Config` (found through the registry, as
`check-config` finds it). The reference lists each key with its type, default, limits
and the `#:` comment written above it in the model's source, so that the documentation
can never drift from what the daemon accepts: a test compares the block in
docs/configuration.md with what this module makes now.

    python -m edged.configdoc                                print the reference (markdown)
    python -m edged.configdoc --write docs/configuration.md  replace the block between the markers
    python -m edged.configdoc --check docs/configuration.md  exit 1 when the block is out of date
"""

from __future__ import annotations

import argparse
import ast
import inspect
import sys
import textwrap
import typing
from functools import cache
from pathlib import Path
from typing import Any

from annotated_types import Ge, Gt, Le, Lt
from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from .config import CoreConfig, RouterConfig
from .registry import Registry

__all__ = ["reference", "BEGIN", "END", "main"]

BEGIN = ("<!-- configuration reference: made by "
         "`python -m edged.configdoc --write docs/configuration.md` -->")
END = "<!-- end of the configuration reference -->"
ROLES = (("inputs", "input"), ("estimators", "estimator"), ("outputs", "output"))


@cache
def _comments(cls: type) -> dict[str, str]:
    """field name -> what the model's source says of it: the comment lines right above
    it (`#:` or `#`); a field right below another with no comment of its own shares
    that one's (one comment above a group of fields); a comment on its own line
    after it (a unit) is added."""
    try:
        lines, _ = inspect.getsourcelines(cls)
    except (OSError, TypeError):
        return {}
    source = textwrap.dedent("".join(lines))
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return {}
    body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
    src = source.splitlines()
    out: dict[str, str] = {}
    group = ""
    last_end = -10
    for node in body:
        if not (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)):
            last_end = -10
            continue
        above: list[str] = []
        i = node.lineno - 2
        while i >= 0 and src[i].strip().startswith("#"):
            above.insert(0, src[i].strip().lstrip("#:").strip())
            i -= 1
        if above:
            group = " ".join(above)
        elif node.lineno - 1 != last_end + 1:
            group = ""  # a blank line (or code) since the last field: a new group
        tail = ""
        end_line = (node.end_lineno or node.lineno) - 1
        code = src[end_line]
        if "#" in code and "  # " in code:
            tail = code.split("  # ", 1)[1].strip()
        text = " ".join(x for x in (group, f"({tail})" if tail else "") if x)
        if text:
            out[node.target.id] = text
        last_end = end_line
    return out


def _comment(model: type[BaseModel], name: str) -> str:
    for cls in model.__mro__:
        if isinstance(cls, type) and issubclass(cls, BaseModel) and name in _comments(cls):
            return _comments(cls)[name]
    return ""


def _type(annotation: Any) -> str:
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin is typing.Literal:
        return " \\| ".join(f'"{a}"' if isinstance(a, str) else str(a) for a in args)
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        return " or ".join(_type(a) for a in args)
    if origin is typing.Annotated:
        return _type(args[0])
    if origin in (list, tuple, set, frozenset):
        inner = ", ".join(_type(a) for a in args if a is not Ellipsis)
        return f"list of {inner}" if inner else "list"
    if origin is dict:
        return f"table of {_type(args[1])}" if len(args) == 2 else "table"
    if annotation is type(None):
        return "none"
    if isinstance(annotation, type):
        if issubclass(annotation, BaseModel):
            return "table"
        return {"str": "string", "int": "integer", "float": "number", "bool": "boolean",
                "Path": "path"}.get(annotation.__name__, annotation.__name__)
    return str(annotation).replace("typing.", "")


def _default(field: Any) -> str:
    if field.is_required():
        return "required"
    if field.default_factory is not None:
        try:
            value = field.default_factory()
        except TypeError:
            return "(computed)"
    else:
        value = field.default
    if value is None and field.validate_default:
        return "(by mode)"  # a None that the model's validator replaces
    if value is None:
        return "none"
    if value is PydanticUndefined:
        return "required"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (list, tuple)) and not value:
        return "[]"
    if isinstance(value, (list, tuple)) and any(isinstance(v, BaseModel) for v in value):
        return f"({len(value)} entries)"
    if isinstance(value, dict) and not value:
        return "{}"
    if isinstance(value, BaseModel):
        return "(table)"
    return str(value).replace("|", "\\|")


def _limits(field: Any) -> str:
    low = high = ""
    for m in field.metadata:
        if isinstance(m, Gt):
            low = f"> {m.gt}"
        elif isinstance(m, Ge):
            low = f"≥ {m.ge}"
        elif isinstance(m, Lt):
            high = f"< {m.lt}"
        elif isinstance(m, Le):
            high = f"≤ {m.le}"
    return ", ".join(x for x in (low, high) if x)


def _table(model: type[BaseModel], skip: frozenset[str] = frozenset()) -> list[str]:
    rows = ["| key | type | default | limits | meaning |", "|---|---|---|---|---|"]
    for name, field in model.model_fields.items():
        if name in skip:
            continue
        what = _comment(model, name).replace("|", "\\|")
        rows.append(f"| `{name}` | {_type(field.annotation)} | {_default(field)} | {_limits(field)} | {what} |")
    return rows


def reference(registry: Registry) -> str:
    """The reference of every table, core first, then each installed plugin by role
    and name (markdown)."""
    out = ["### `[edged]`", "", *_table(CoreConfig), "", "### `[router]`", "", *_table(RouterConfig), ""]
    for role, word in ROLES:
        for name, cls in sorted(registry.iter(role), key=lambda nc: nc[0]):
            config = getattr(cls, "Config", None)
            if not (isinstance(config, type) and issubclass(config, BaseModel)):
                continue
            own = cls.__dict__.get("__doc__") or ""  # its own, not a base class's
            doc = inspect.cleandoc(own).split("\n\n")[0].replace("\n", " ") if own else ""
            out += [f"### `[{role}.<name>]` with `type = \"{name}\"` ({word})", ""]
            if doc:
                out += [doc, ""]
            out += [*_table(config, frozenset({"type"})), ""]
    return "\n".join(out).rstrip() + "\n"


def _splice(text: str, block: str) -> str:
    start = text.index(BEGIN) + len(BEGIN)
    end = text.index(END)
    return text[:start] + "\n\n" + block + "\n" + text[end:]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m edged.configdoc", description=__doc__.split("\n\n")[0])
    group = ap.add_mutually_exclusive_group()
    group.add_argument("--write", metavar="FILE", help="replace the reference block in FILE")
    group.add_argument("--check", metavar="FILE", help="exit 1 when FILE's block is out of date")
    args = ap.parse_args(argv)
    block = reference(Registry())
    target = args.write or args.check
    if target is None:
        sys.stdout.write(block)
        return 0
    path = Path(target)
    text = path.read_text(encoding="utf-8")
    if BEGIN not in text or END not in text:
        print(f"{path}: no reference block (the markers {BEGIN!r} … {END!r})", file=sys.stderr)
        return 2
    new = _splice(text, block)
    if args.check:
        if new != text:
            print(f"{path}: the configuration reference is out of date: "
                  f"run `python -m edged.configdoc --write {path}`", file=sys.stderr)
            return 1
        return 0
    if new != text:
        path.write_text(new, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
