"""The configuration a core subcommand runs with: the file (or the embedded default),
the command line's overrides (`--vessel-id`) and options (`--zenoh-config`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from .config import Config, ConfigError, default_config, load_config
from .registry import Registry


def load_for(path: str | None, registry: Registry) -> Config:
    return load_config(path, registry) if path else default_config(registry)


def with_overrides(cfg: Config, args: argparse.Namespace) -> Config:
    if getattr(args, "vessel_id", None) is not None:
        try:
            cfg.edged = cfg.edged.model_validate({**cfg.edged.model_dump(), "vessel_id": args.vessel_id})
        except ValidationError as exc:
            raise ConfigError("--vessel-id", [("vessel_id", e["msg"]) for e in exc.errors()]) from None
    return cfg


def command_options(args: argparse.Namespace) -> dict[str, Any]:
    opts: dict[str, Any] = {}
    zc = getattr(args, "zenoh_config", None)
    if zc:
        p = Path(zc)
        if not p.is_file():
            raise ConfigError(str(p), [("--zenoh-config", "no such file")])
        try:
            p.read_bytes().decode("utf-8")
        except OSError as exc:
            raise ConfigError(str(p), [("--zenoh-config", f"cannot read: {exc.strerror or exc}")]) from None
        except UnicodeDecodeError as exc:
            raise ConfigError(str(p), [("--zenoh-config", f"not a json5 text file (byte {exc.start} is no UTF-8)")]) from None
        opts["zenoh_config"] = str(p.resolve())
    return opts
