"""Configuration: TOML, validated against typed schemas before anything starts.

Layout of a configuration file:

    [edged]                 core settings (CoreConfig)
    [router]                queue sizes, source priority (RouterConfig)
    [inputs.<name>]         one table per input; `type` picks the plugin, <name> is
    [estimators.<name>]     the source / worker / output name used in topics and health
    [outputs.<name>]

Each plugin validates its own table with its own schema. Every error names the file,
the key path and the reason (`edged.toml: inputs.gnss1.port: Input should be a valid
integer`), and all errors of a file are reported at once. No number may be `inf` or
`nan`, and each is bounded: what `check-config` passes, `run` starts with.

Across tables: a name is used by one input, estimator or output only (it is the
source, estimate or output name in topics, health and logs), and no two enabled
plugins may claim the same exclusive resource (`PluginConfig.claims`: two inputs
listening on one UDP port, two reading one serial device).
"""

from __future__ import annotations

import os
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator

from .backoff import Backoff

from .plugin import Claim, PluginConfig
from .records import KINDS
from .registry import PluginNotFound, Registry

ROLES = ("inputs", "estimators", "outputs")
_NAME_RE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]*")


def known_kind(name: str) -> str:
    """A measurement kind of DESIGN §2, or a ValueError listing them."""
    if name not in KINDS:
        raise ValueError(f"unknown measurement kind {name!r} (known: {', '.join(KINDS)})")
    return name


#: A configuration value naming a measurement kind (plugins map signals and keys onto one).
KindName = Annotated[str, AfterValidator(known_kind)]


def valid_name(name: str) -> str:
    """A source, estimate or plugin name (one Zenoh key segment), or a ValueError."""
    if not _NAME_RE.fullmatch(name):
        raise ValueError(f"{name!r}: letters, digits, '_', '-' and '.' only (it is a Zenoh key segment)")
    return name


#: A configuration value that becomes a source name (or part of one) in topics and health.
SourceName = Annotated[str, AfterValidator(valid_name)]


#: Longest wait between two attempts to (re)open a link, in seconds: a day.
MAX_BACKOFF = 86_400.0
#: Longest a watchdog may wait for a silent link, in seconds: a day.
MAX_WATCHDOG = 86_400.0


def not_below(v: float, info: ValidationInfo, lower: str) -> float:
    """A field validator's check that `v` is at least the already validated `lower`
    field (a backoff's maximum and its initial delay)."""
    low = info.data.get(lower)
    if low is not None and v < low:
        raise ValueError(f"must be >= {lower} ({low})")
    return v


class ReconnectSettings(BaseModel):
    """Mixin for a plugin that (re)opens a link: the delays between attempts."""

    model_config = ConfigDict(allow_inf_nan=False)

    #: Seconds before the first reconnect attempt; doubled after each failure ...
    backoff_initial: float = Field(0.5, gt=0, le=MAX_BACKOFF)
    #: ... up to this many seconds.
    backoff_max: float = Field(30.0, gt=0, le=MAX_BACKOFF)

    @field_validator("backoff_max")
    @classmethod
    def _backoff_order(cls, v: float, info: ValidationInfo) -> float:
        return not_below(v, info, "backoff_initial")

    def backoff(self) -> Backoff:
        return Backoff(self.backoff_initial, self.backoff_max)


class ConfigError(Exception):
    """One or more configuration errors; `str()` lists them one per line."""

    def __init__(self, file: str, errors: list[tuple[str, str]]) -> None:
        self.file = file
        self.errors = errors
        super().__init__("\n".join(f"{file}: {k}: {r}" if k else f"{file}: {r}" for k, r in errors))


class CoreConfig(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    #: The vessel's id: the Zenoh key prefix is vessel/<vessel_id>/ (letters, digits, _ - .).
    vessel_id: str = "vessel"
    #: What the log says: info logs state changes and errors, never a line per message.
    log_level: Literal["debug", "info", "warning", "error"] = "info"
    #: Also log to this file (reopened on SIGHUP); stderr is always used.
    log_file: str | None = None
    #: Seconds between health snapshots sent to the outputs.
    health_interval: float = Field(1.0, gt=0, le=3600.0)
    #: Seconds the shutdown may take before outputs are abandoned (at most 10 min).
    shutdown_timeout: float = Field(5.0, gt=0, le=600.0)

    @field_validator("log_file")
    @classmethod
    def _log_file(cls, v: str | None) -> str | None:
        """The file `run` opens before anything starts: a missing folder is an error now."""
        if not v:
            return v
        p = Path(v)
        if p.is_dir():
            raise ValueError(f"{v!r} is a directory")
        if not p.parent.is_dir():
            raise ValueError(f"{v!r}: no directory {str(p.parent)!r}")
        if not os.access(p if p.exists() else p.parent, os.W_OK):
            raise ValueError(f"{v!r} cannot be written (permission denied)")
        return v

    @field_validator("vessel_id")
    @classmethod
    def _vessel_id(cls, v: str) -> str:
        if not _NAME_RE.fullmatch(v) or "/" in v:
            raise ValueError("letters, digits, '_', '-' and '.' only (it is a Zenoh key segment)")
        return v


class RouterConfig(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    #: Seconds of data time a preferred source may be silent before the next takes over.
    failover_timeout: float = Field(2.0, gt=0, le=86_400.0)
    #: Per measurement kind, the sources in order of preference.
    priority: dict[str, list[str]] = Field(default_factory=dict)

    @field_validator("priority")
    @classmethod
    def _kinds(cls, v: dict[str, list[str]]) -> dict[str, list[str]]:
        for kind, sources in v.items():
            known_kind(kind)
            if len(set(sources)) != len(sources):
                raise ValueError(f"{kind}: a source is listed twice")
        return v


#: What one configuration may ask for, per role (issue 32: 500 draft instances passed
#: check-config; twenty took 3.36 GB, 168 MB each). A gateway computer has a few GB:
#: an estimator or output in a process of its own costs 100–200 MB, an input a task
#: and its buffers. Generous for any real vessel (three estimators, a recorder, a
#: publisher, a dozen sensors), and refused with the count where it is not.
MAX_INSTANCES = {"inputs": 64, "estimators": 12, "outputs": 12}
MAX_WHY = {
    "inputs": "each holds a connection and its buffers",
    "estimators": "each may run in a process of its own, 100-200 MB",
    "outputs": "each may run in a process of its own, 100-200 MB",
}


@dataclass
class Config:
    """A validated configuration: core sections and each plugin's validated section."""

    edged: CoreConfig = field(default_factory=CoreConfig)
    router: RouterConfig = field(default_factory=RouterConfig)
    inputs: dict[str, PluginConfig] = field(default_factory=dict)
    estimators: dict[str, PluginConfig] = field(default_factory=dict)
    outputs: dict[str, PluginConfig] = field(default_factory=dict)
    path: Path | None = None
    text: str = ""

    @property
    def config_dir(self) -> Path:
        return self.path.parent if self.path else Path.cwd()


def _loc(prefix: str, loc: tuple[Any, ...]) -> str:
    parts = [prefix] if prefix else []
    parts += [str(p) for p in loc]
    return ".".join(parts)


def _pydantic_errors(prefix: str, exc: ValidationError) -> list[tuple[str, str]]:
    out = []
    for e in exc.errors():
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            msg = "unknown key"
        elif "input" in e and e["type"] not in ("missing",) and not isinstance(e["input"], dict):
            msg = f"{msg} (got {e['input']!r})"
        out.append((_loc(prefix, e["loc"]), msg))
    return out


def parse_config(
    data: dict[str, Any], registry: Registry, *, file: str = "<config>", config_dir: Path | None = None
) -> Config:
    """Validate a configuration already read into a dict."""
    errors: list[tuple[str, str]] = []
    cfg = Config()
    for key in data:
        if key not in ("edged", "router", *ROLES):
            errors.append((key, "unknown section (expected edged, router, inputs, estimators, outputs)"))
    for key, model in (("edged", CoreConfig), ("router", RouterConfig)):
        section = data.get(key, {})
        if not isinstance(section, dict):
            errors.append((key, "must be a table"))
            continue
        try:
            setattr(cfg, key, model.model_validate(section))
        except ValidationError as exc:
            errors += _pydantic_errors(key, exc)
    ctx = {"config_dir": config_dir or Path.cwd()}
    for role in ROLES:
        section = data.get(role, {})
        if not isinstance(section, dict):
            errors.append((role, "must be a table of named plugins"))
            continue
        if len(section) > MAX_INSTANCES[role]:
            errors.append((role, f"{len(section)} instances: at most {MAX_INSTANCES[role]} "
                                 f"({MAX_WHY[role]})"))
            continue
        for name, body in section.items():
            where = f"{role}.{name}"
            if not _NAME_RE.fullmatch(name):
                errors.append((where, "name: letters, digits, '_', '-' and '.' only"))
                continue
            if not isinstance(body, dict):
                errors.append((where, "must be a table"))
                continue
            type_ = body.get("type")
            if not isinstance(type_, str):
                errors.append((f"{where}.type", "missing: which plugin to use"))
                continue
            try:
                cls = registry.get(role, type_)
            except PluginNotFound as exc:
                errors.append((f"{where}.type", str(exc)))
                continue
            try:
                getattr(cfg, role)[name] = cls.Config.model_validate(body, context=ctx)
            except ValidationError as exc:
                errors += _pydantic_errors(where, exc)
    errors += _name_collisions(data)
    errors += _claim_collisions(cfg)
    if errors:
        raise ConfigError(file, errors)
    return cfg


def _name_collisions(data: dict[str, Any]) -> list[tuple[str, str]]:
    """One name, two roles: `inputs.x and outputs.x: ...` (a name is one thing)."""
    first: dict[str, str] = {}
    out: list[tuple[str, str]] = []
    for role in ROLES:
        section = data.get(role)
        if not isinstance(section, dict):
            continue
        for name in section:
            where = f"{role}.{name}"
            if name in first:
                out.append((
                    f"{first[name]} and {where}",
                    f"the name {name!r} is used twice: an input, an estimator and an output "
                    "each need their own (it is the source, estimate or output name in topics, "
                    "health and logs)",
                ))
            else:
                first[name] = where
    return out


def _overlap(a: tuple[str, ...], b: tuple[str, ...]) -> bool:
    return len(a) == len(b) and all(x == y or x == "*" or y == "*" for x, y in zip(a, b))


def _claim_collisions(cfg: Config) -> list[tuple[str, str]]:
    """Two enabled plugins claiming one exclusive resource, named by both keys."""
    held: list[tuple[str, Claim]] = []
    out: list[tuple[str, str]] = []
    for role in ROLES:
        for name, c in getattr(cfg, role).items():
            if not c.enabled:
                continue
            for claim in c.claims():
                where = f"{role}.{name}.{claim.key}"
                for other_where, other in held:
                    if _overlap(other.resource, claim.resource):
                        if other.text == claim.text:
                            reason = f"both {claim.text}"
                        else:
                            reason = f"both want the same resource ({other.text}; {claim.text})"
                        out.append((f"{other_where} and {where}", reason))
                        break
                held.append((where, claim))
    return out


def load_config(path: str | Path, registry: Registry) -> Config:
    """Read and validate a TOML configuration file; raise ConfigError naming the key."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(str(p), [("", f"cannot read: {exc.strerror or exc}")]) from None
    except UnicodeDecodeError as exc:
        raise ConfigError(str(p), [("", f"not UTF-8 text: {exc}")]) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(str(p), [("", f"TOML syntax: {exc}")]) from None
    cfg = parse_config(data, registry, file=str(p), config_dir=p.resolve().parent)
    cfg.path = p
    cfg.text = text
    return cfg


def default_config(registry: Registry, vessel_id: str = "vessel") -> Config:
    """The built-in configuration: every installed estimator on, defaults everywhere."""
    data: dict[str, Any] = {
        "edged": {"vessel_id": vessel_id},
        "estimators": {name: {"type": name} for name in registry.names("estimators")},
    }
    return parse_config(data, registry, file="<built-in default>")
