"""The layers of the code base, read from its source: who may import whom, and how big.

Why a test: the rules below were each broken once without anyone noticing (issue 33:
the CAN plugin needed the NMEA 0183 plugin for its serial port, two NMEA 0183 modules
imported each other). Every import is read with `ast` from every `.py` file of
`edged/` and `plugins/`, those inside functions included (an import deferred to a
call is still a dependency), and checked against:
- the core (`edged`) imports no plugin package (`edged_*`): it knows no sensor;
- a plugin imports no other plugin, but `edged_demo` may import `edged_sim` (the demo
  runs the simulator);
- no import cycle among the modules;
- no file over MAX_FILE_LINES lines, no function (methods included) over
  MAX_FUNCTION_LINES lines, from its `def` line to its last.
Each failure lists every offender, so one run shows all there is to fix.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CORE = "edged"
#: Plugin-to-plugin imports that are allowed: (importer, imported) top-level packages.
ALLOWED_PLUGIN_IMPORTS = {("edged_demo", "edged_sim")}
MAX_FILE_LINES = 450
MAX_FUNCTION_LINES = 60


@dataclass(frozen=True)
class Source:
    """One module of the code base: its dotted name, its file, its parsed text."""

    name: str
    path: Path
    is_package: bool
    tree: ast.Module

    @property
    def top(self) -> str:
        return self.name.split(".")[0]

    def where(self) -> str:
        return str(self.path.relative_to(ROOT))


def _module_name(path: Path, base: Path) -> tuple[str, bool]:
    parts = list(path.relative_to(base).with_suffix("").parts)
    if parts[-1] == "__init__":
        return ".".join(parts[:-1]), True
    return ".".join(parts), False


def _sources() -> dict[str, Source]:
    """Every module of `edged/` and of each `plugins/edged_*/` package, by name."""
    found: dict[str, Source] = {}
    roots = [(ROOT / CORE, ROOT)] + [(p, ROOT / "plugins") for p in sorted((ROOT / "plugins").glob("edged_*"))]
    for folder, base in roots:
        for path in sorted(folder.rglob("*.py")):
            name, is_package = _module_name(path, base)
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            found[name] = Source(name, path, is_package, tree)
    return found


SOURCES = _sources()


def _absolute(src: Source, node: ast.ImportFrom) -> str:
    """The module a `from … import` names, its dots resolved against `src`'s package."""
    if not node.level:
        return node.module or ""
    package = src.name.split(".") if src.is_package else src.name.split(".")[:-1]
    base = package[: len(package) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports_of(src: Source) -> Iterator[tuple[str, int]]:
    """(module imported, line) for every import statement of `src`, at any depth.
    `from pkg import name` imports the module `pkg.name` when there is one, else `pkg`."""
    for node in ast.walk(src.tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            module = _absolute(src, node)
            for alias in node.names:
                sub = f"{module}.{alias.name}"
                yield (sub if sub in SOURCES else module), node.lineno


def _is_plugin(top: str) -> bool:
    return top.startswith("edged_")


def test_the_core_imports_no_plugin() -> None:
    bad = [
        f"{src.where()}:{line} imports {target}"
        for src in SOURCES.values()
        if src.top == CORE
        for target, line in imports_of(src)
        if _is_plugin(target.split(".")[0])
    ]
    assert not bad, "the core (edged/) must not import a plugin package:\n" + "\n".join(bad)


def test_no_plugin_imports_another() -> None:
    bad = []
    for src in SOURCES.values():
        if not _is_plugin(src.top):
            continue
        for target, line in imports_of(src):
            other = target.split(".")[0]
            if _is_plugin(other) and other != src.top and (src.top, other) not in ALLOWED_PLUGIN_IMPORTS:
                bad.append(f"{src.where()}:{line} imports {target}")
    assert not bad, (
        "a plugin must not import another plugin (shared code goes to the core, edged/):\n" + "\n".join(bad)
    )


def _graph() -> dict[str, set[str]]:
    return {
        name: {target for target, _ in imports_of(src) if target in SOURCES and target != name}
        for name, src in SOURCES.items()
    }


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative:
    no recursion limit whatever the depth of the imports)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def a_cycle(graph: dict[str, set[str]], component: list[str]) -> list[str]:
    """One cycle through the first module of `component`, as the modules in import
    order (breadth first: the shortest), for the failure message."""
    members = set(component)
    start = component[0]
    came_from: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for child in sorted(graph[node] & members):
                if child == start:
                    path = [node]
                    while path[-1] != start:
                        path.append(came_from[path[-1]])
                    return [*reversed(path), start]
                if child not in came_from:
                    came_from[child] = node
                    following.append(child)
        frontier = following
    return component


def test_no_import_cycles() -> None:
    graph = _graph()
    cycles = [" -> ".join(a_cycle(graph, c)) for c in strongly_connected(graph)]
    assert not cycles, "import cycles (modules that import each other, at any depth):\n" + "\n".join(cycles)


def _functions(tree: ast.Module) -> Iterator[ast.FunctionDef | ast.AsyncFunctionDef]:
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node


def test_files_and_functions_are_small() -> None:
    bad = []
    for src in SOURCES.values():
        lines = len(src.path.read_text(encoding="utf-8").splitlines())
        if lines > MAX_FILE_LINES:
            bad.append(f"{src.where()}: {lines} lines (file, at most {MAX_FILE_LINES})")
        for fn in _functions(src.tree):
            length = (fn.end_lineno or fn.lineno) - fn.lineno + 1
            if length > MAX_FUNCTION_LINES:
                bad.append(f"{src.where()}:{fn.lineno} {fn.name}: {length} lines (function, at most {MAX_FUNCTION_LINES})")
    assert not bad, f"{len(bad)} too big:\n" + "\n".join(bad)


def test_the_walk_sees_the_imports_it_checks() -> None:
    """The checks above are only as good as the walk: it finds the modules, resolves
    relative imports and sees imports inside functions."""
    assert {"edged.records", "edged_can.formats", "edged_nmea0183.logs"} <= SOURCES.keys()
    found = dict(imports_of(SOURCES["edged_can.logs"]))
    assert "edged_can.candump" in found  # `from . import candump`, inside a method
    assert "edged.health" in found
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert strongly_connected(graph) == [["a", "b", "c"]]
    assert a_cycle(graph, ["a", "b", "c"]) == ["a", "b", "c", "a"]
