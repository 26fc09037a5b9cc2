"""Plugin discovery through entry points.

A third party adds an input, estimator, output, log reader (`edged.plugin.LogReader`,
one per file format `edged replay` reads) or command by installing a package that
declares an entry point in one of these groups; edged itself registers its own
plugins the same way (pyproject.toml), so there is no privileged built-in list.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from importlib.metadata import EntryPoint, entry_points
from typing import Any, Iterator

log = logging.getLogger("edged.registry")

GROUPS = {
    "inputs": "edged.inputs",
    "estimators": "edged.estimators",
    "outputs": "edged.outputs",
    #: reader objects (not classes) of log formats for `edged replay`
    "logs": "edged.logs",
    #: reader objects of recording formats for `edged score`/`plot` (edged.recordings)
    "recordings": "edged.recordings",
    "commands": "edged.commands",
}


class PluginNotFound(LookupError):
    pass


@dataclass
class Registry:
    """Plugin classes by role and type name; loaded lazily from entry points.

    The entry points of a group are looked up once per registry: each look-up scans
    the metadata of every installed distribution (about 10 ms), and a command asks
    for several plugins. A registry lives for one command, so a package installed
    while it runs is seen by the next command.
    """

    extra: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: False: only what was `register`ed (tests that must not see installed plugins).
    use_entry_points: bool = True
    _cache: dict[tuple[str, str], Any] = field(default_factory=dict)
    _entry_points: dict[str, dict[str, EntryPoint]] = field(default_factory=dict)

    def _group(self, role: str) -> dict[str, EntryPoint]:
        """name -> entry point of `role` (the first of a name, as a look-up by name gives)."""
        eps = self._entry_points.get(role)
        if eps is None:
            eps = {}
            if self.use_entry_points:
                for ep in entry_points(group=GROUPS[role]):
                    eps.setdefault(ep.name, ep)
            self._entry_points[role] = eps
        return eps

    def names(self, role: str) -> list[str]:
        return sorted(set(self._group(role)) | set(self.extra.get(role, {})))

    def get(self, role: str, name: str) -> Any:
        """The plugin class (command function, log reader) `name` of `role`."""
        extra = self.extra.get(role, {})
        if name in extra:
            return extra[name]
        key = (role, name)
        if key in self._cache:
            return self._cache[key]
        ep = self._group(role).get(name)
        if ep is not None:
            obj = ep.load()
            self._cache[key] = obj
            return obj
        raise PluginNotFound(
            f"no {role[:-1]} plugin named {name!r} (installed: {', '.join(self.names(role)) or 'none'})"
        )

    def all(self, role: str) -> dict[str, Any]:
        return dict(self.iter(role))

    def iter(self, role: str) -> Iterator[tuple[str, Any]]:
        """(name, class) of every plugin of `role` in name order, each loaded only when
        the iteration reaches it: a caller that stops early (the first plugin that
        reads a file) does not pay for importing the others."""
        for n in self.names(role):
            try:
                obj = self.get(role, n)
            except Exception as exc:  # a broken third-party plugin must not stop edged
                log.warning("plugin=%s role=%s load failed: %s", n, role, exc)
                continue
            yield n, obj

    def register(self, role: str, name: str, obj: Any) -> None:
        """Add a plugin by hand (tests, embedding)."""
        self.extra.setdefault(role, {})[name] = obj
