"""Plugin discovery through entry points.

A third party adds an input, estimator, output or command by installing a package
that declares an entry point in one of these groups; edged itself registers its own
plugins the same way (pyproject.toml), so there is no privileged built-in list.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import Any

log = logging.getLogger("edged.registry")

GROUPS = {
    "inputs": "edged.inputs",
    "estimators": "edged.estimators",
    "outputs": "edged.outputs",
    "commands": "edged.commands",
}


class PluginNotFound(LookupError):
    pass


@dataclass
class Registry:
    """Plugin classes by role and type name; loaded lazily from entry points."""

    extra: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: False: only what was `register`ed (tests that must not see installed plugins).
    use_entry_points: bool = True
    _cache: dict[tuple[str, str], Any] = field(default_factory=dict)

    def names(self, role: str) -> list[str]:
        eps = {ep.name for ep in entry_points(group=GROUPS[role])} if self.use_entry_points else set()
        return sorted(eps | set(self.extra.get(role, {})))

    def get(self, role: str, name: str) -> Any:
        """The plugin class (or command function) `name` of `role`."""
        extra = self.extra.get(role, {})
        if name in extra:
            return extra[name]
        key = (role, name)
        if key in self._cache:
            return self._cache[key]
        for ep in entry_points(group=GROUPS[role], name=name) if self.use_entry_points else ():
            obj = ep.load()
            self._cache[key] = obj
            return obj
        raise PluginNotFound(
            f"no {role[:-1]} plugin named {name!r} (installed: {', '.join(self.names(role)) or 'none'})"
        )

    def all(self, role: str) -> dict[str, Any]:
        out = {}
        for n in self.names(role):
            try:
                out[n] = self.get(role, n)
            except Exception as exc:  # a broken third-party plugin must not stop edged
                log.warning("plugin=%s role=%s load failed: %s", n, role, exc)
        return out

    def register(self, role: str, name: str, obj: Any) -> None:
        """Add a plugin by hand (tests, embedding)."""
        self.extra.setdefault(role, {})[name] = obj
