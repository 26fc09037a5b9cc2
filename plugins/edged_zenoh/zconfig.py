"""Zenoh configuration: the safe defaults and the json5 drop-in, in one representation.

Every session edged opens (output, input, `edged router`, `edged fleet`) is described
by a plain nested dict in zenoh's own configuration schema. It is built by merging, in
order of increasing precedence:

1. the safe defaults of DESIGN §6 (`safe_defaults`): localhost only, no scouting, so a
   fresh install exposes nothing on the ship's network;
2. the plugin's explicit settings (`mode`, `listen`, `connect`, `tls`);
3. the json5 file named by the plugin's `zenoh_config`;
4. the json5 file given on the command line (`--zenoh-config`).

Files are merged key by key (objects recursively, lists and scalars replaced), so a
user file that only says `{connect: {endpoints: ["tls/shore:7447"]}}` keeps the rest of
the defaults. Only at the very end is the dict handed to `zenoh.Config.from_json5`,
which is the authority on what zenoh accepts.
"""

from __future__ import annotations

import copy
import ipaddress
import json
import re
import socket
from pathlib import Path
from typing import Any, Literal, Mapping

import json5
import zenoh
from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

from edged.config import not_below
from edged.plugin import Claim, listen_claim

__all__ = [
    "DEFAULT_PORT",
    "DEFAULT_LISTEN",
    "ZenohConfigError",
    "TlsSettings",
    "ZenohSettings",
    "safe_defaults",
    "merge",
    "load_json5",
    "to_zenoh",
    "session_config",
    "listen_endpoints",
    "connect_endpoints",
    "unguarded_endpoints",
    "with_listen_endpoints",
    "endpoint_in_use",
    "free_port_endpoint",
    "check_key_prefix",
]

DEFAULT_PORT = 7447
DEFAULT_LISTEN = f"tcp/127.0.0.1:{DEFAULT_PORT}"

_ENDPOINT_RE = re.compile(r"^[a-z0-9]+/[^\s]+$")
_TCP_RE = re.compile(r"^(?P<proto>tcp|tls)/(?P<host>\[[^\]]+\]|[^:/\[\]]+):(?P<port>\d+)(?P<rest>[#?].*)?$")
_WILD_RE = re.compile(r"[*$?#]")
#: Any endpoint with an address and a port, and the transport protocol its port is of.
_PORT_RE = re.compile(r"^(?P<proto>[a-z0-9]+)/(?P<host>\[[^\]]+\]|[^:/\[\]]+):(?P<port>\d+)(?P<rest>[#?/].*)?$")
_PORT_PROTO = {"tcp": "tcp", "tls": "tcp", "ws": "tcp", "udp": "udp", "quic": "udp"}
#: Longest wait between two session open attempts, in seconds: a day.
MAX_RETRY = 86_400.0


class ZenohConfigError(ValueError):
    """A zenoh configuration that cannot be used; the message names its origin."""


def safe_defaults(
    mode: str = "peer",
    listen: list[str] | tuple[str, ...] = (DEFAULT_LISTEN,),
    connect: list[str] | tuple[str, ...] = (),
) -> dict[str, Any]:
    """The defaults of DESIGN §6: explicit endpoints only, no multicast nor gossip.

    Gossip is switched off as well as multicast because a gossiping peer would tell
    other peers about endpoints it learnt, which is discovery by another name.
    """
    return {
        "mode": mode,
        "listen": {"endpoints": list(listen)},
        "connect": {"endpoints": list(connect)},
        "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
    }


def merge(base: Mapping[str, Any], overlay: Mapping[str, Any]) -> dict[str, Any]:
    """A new dict: `overlay` over `base`, objects merged recursively, the rest replaced."""
    out = copy.deepcopy(dict(base))
    for key, value in overlay.items():
        old = out.get(key)
        if isinstance(old, dict) and isinstance(value, Mapping):
            out[key] = merge(old, value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def load_json5(path: str | Path) -> dict[str, Any]:
    """Read a zenoh json5 file; ZenohConfigError names the file and the reason."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ZenohConfigError(f"{p}: cannot read: {exc}") from None
    try:
        data = json5.loads(text)
    except ValueError as exc:
        raise ZenohConfigError(f"{p}: json5 syntax: {exc}") from None
    if not isinstance(data, dict):
        raise ZenohConfigError(f"{p}: the top level must be an object")
    return data


def to_zenoh(cfg: Mapping[str, Any], origin: str = "zenoh configuration") -> zenoh.Config:
    """The zenoh.Config of a merged dict; zenoh itself judges what is valid."""
    try:
        return zenoh.Config.from_json5(json.dumps(cfg))
    except zenoh.ZError as exc:
        raise ZenohConfigError(f"{origin}: rejected by zenoh: {exc}") from None


def _resolve(path: str | Path, base: Path) -> Path:
    p = Path(path).expanduser()
    return p if p.is_absolute() else (base / p)


class TlsSettings(BaseModel):
    """zenoh's `transport/link/tls` section, passed through as is (paths resolved).

    Relative certificate paths are taken relative to the edged configuration file, so a
    site folder with its config and certificates can be moved as a whole.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    root_ca_certificate: str | None = None
    listen_certificate: str | None = None
    listen_private_key: str | None = None
    connect_certificate: str | None = None
    connect_private_key: str | None = None
    enable_mtls: bool | None = None
    verify_name_on_connect: bool | None = None

    def to_zenoh_dict(self, base: Path) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for name, value in self.model_dump(exclude_none=True).items():
            if isinstance(value, str):
                value = str(_resolve(value, base))
            out[name] = value
        return out


class ZenohSettings(BaseModel):
    """The session settings every zenoh plugin of edged accepts (a configuration mixin)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    #: `peer` (reachable without any router) or `client` (through a router or peer).
    #: Unset, the plugin's own default applies (the output: peer; the input: client).
    mode: Literal["peer", "client"] = "peer"
    #: Endpoints to listen on; default tcp/127.0.0.1:7447 for a peer, none for a client.
    listen: list[str] | None = None
    #: Endpoints of routers or peers to connect to.
    connect: list[str] | None = None
    tls: TlsSettings | None = None
    #: A zenoh json5 file merged over the defaults and the settings above.
    zenoh_config: Path | None = None
    #: When a listen port is taken, listen on a free port instead (logged, in health).
    listen_fallback: bool = True
    #: Seconds before the first retry of a failed session open, doubled up to retry_max.
    retry_initial: float = Field(0.5, gt=0, le=MAX_RETRY)
    retry_max: float = Field(30.0, gt=0, le=MAX_RETRY)

    @field_validator("listen", "connect")
    @classmethod
    def _endpoints(cls, v: list[str] | None) -> list[str] | None:
        for ep in v or ():
            if not _ENDPOINT_RE.match(ep):
                raise ValueError(f"{ep!r} is not a zenoh endpoint like 'tcp/127.0.0.1:7447'")
            m = _PORT_RE.match(ep)
            if m is not None and not 0 <= int(m["port"]) <= 65535:
                raise ValueError(f"{ep!r}: port {int(m['port'])} outside 0..65535")
        return v

    @field_validator("retry_max")
    @classmethod
    def _retry_order(cls, v: float, info: ValidationInfo) -> float:
        return not_below(v, info, "retry_initial")

    def claims(self) -> list[Claim]:
        """The ports of the `listen` endpoints it names.

        Two sessions of one configuration naming one endpoint never both get it: the
        second fails, or with `listen_fallback` listens on some free port no peer
        knows of (the fallback is for a port held outside edged). Only the endpoints
        listed here are known before start (not those of a `zenoh_config` file, nor a
        plugin's default); a port 0 asks for any free port and claims nothing.
        """
        out: list[Claim] = []
        nxt = getattr(super(), "claims", None)
        if nxt is not None:
            out += nxt()
        for i, ep in enumerate(self.listen or ()):
            m = _PORT_RE.match(ep)
            proto = _PORT_PROTO.get(m["proto"]) if m else None
            if m is None or proto is None or int(m["port"]) == 0:
                continue
            out.append(listen_claim(f"listen.{i}", proto, m["host"], m["port"], f"listen on {ep}"))
        return out

    @field_validator("zenoh_config")
    @classmethod
    def _zenoh_file(cls, v: Path | None, info: ValidationInfo) -> Path | None:
        """Resolve and check the file at configuration time, so start-up names the key."""
        if v is None:
            return None
        base = (info.context or {}).get("config_dir") or Path.cwd()
        p = _resolve(v, Path(base))
        to_zenoh(merge(safe_defaults(), load_json5(p)), str(p))
        return p

    def overlay(self, config_dir: Path) -> dict[str, Any]:
        """The part of the zenoh dict these settings state explicitly."""
        explicit = self.model_fields_set
        out: dict[str, Any] = {"mode": self.mode} if "mode" in explicit else {}
        if self.listen is not None:
            out["listen"] = {"endpoints": list(self.listen)}
        elif "mode" in explicit and self.mode == "client":
            out["listen"] = {"endpoints": []}
        if self.connect is not None:
            out["connect"] = {"endpoints": list(self.connect)}
        if self.tls is not None:
            out["transport"] = {"link": {"tls": self.tls.to_zenoh_dict(config_dir)}}
        return out


def session_config(
    settings: ZenohSettings,
    *,
    config_dir: Path,
    cli_file: str | Path | None = None,
    base: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The merged zenoh dict of a plugin: defaults < settings < its file < command line."""
    cfg = merge(base if base is not None else safe_defaults(), settings.overlay(config_dir))
    if settings.zenoh_config is not None:
        cfg = merge(cfg, load_json5(_resolve(settings.zenoh_config, config_dir)))
    if cli_file:
        cfg = merge(cfg, load_json5(cli_file))
    return cfg


def listen_endpoints(cfg: Mapping[str, Any]) -> list[str]:
    """The endpoints this session will listen on (zenoh allows a list per mode)."""
    eps = (cfg.get("listen") or {}).get("endpoints") or []
    if isinstance(eps, Mapping):
        eps = eps.get(cfg.get("mode", "peer")) or []
    return list(eps)


def connect_endpoints(cfg: Mapping[str, Any]) -> list[str]:
    """The endpoints this session will connect to (zenoh allows a list per mode)."""
    eps = (cfg.get("connect") or {}).get("endpoints") or []
    if isinstance(eps, Mapping):
        eps = eps.get(cfg.get("mode", "peer")) or []
    return list(eps)


#: Link protocols whose far end proves who it is (a certificate checked against a CA).
_AUTHENTICATED_LINKS = {"tls", "quic"}


def _network_host(endpoint: str) -> tuple[str, str] | None:
    """(protocol, host) of an endpoint other hosts can be at the far end of; None for
    loopback addresses and endpoints without an address (unix sockets)."""
    m = _PORT_RE.match(endpoint)
    if m is None:
        return None
    host = m["host"].strip("[]").lower()
    if host == "localhost" or host.endswith(".localhost"):
        return None
    try:
        if ipaddress.ip_address(host.split("%")[0]).is_loopback:
            return None
    except ValueError:
        pass  # a host name: not known to be this computer
    return m["proto"], host


def unguarded_endpoints(cfg: Mapping[str, Any]) -> list[str]:
    """Where hosts other than this one can reach the session with no access control.

    The session's own access control (`access_control` enabled, default deny) guards
    everything. Otherwise: a listen endpoint on a non-loopback address, unless the
    session refuses sessions that do not log in (a `transport/auth/usrpwd` dictionary)
    or it is a tls/quic endpoint with mutual TLS; a connect
    endpoint to another host over a link that does not authenticate that host (not
    tls/quic: there the far end's access control decides, as router-tls.json5 does);
    and multicast scouting, which connects to whatever answers on the network. Read
    from the configuration as zenoh sees it (its defaults included).
    """
    z = to_zenoh(cfg)

    def get(key: str) -> Any:
        return json.loads(z.get_json(key))

    acl = get("access_control") or {}
    if acl.get("enabled") and acl.get("default_permission") == "deny":
        return []
    auth = get("transport/auth") or {}
    logins = bool((auth.get("usrpwd") or {}).get("dictionary_file"))
    mtls = bool((get("transport/link/tls") or {}).get("enable_mtls"))
    out: list[str] = []
    for ep in listen_endpoints(cfg):
        net = _network_host(ep)
        if net is not None and not logins and not (net[0] in _AUTHENTICATED_LINKS and mtls):
            out.append(ep)
    for ep in connect_endpoints(cfg):
        net = _network_host(ep)
        if net is not None and net[0] not in _AUTHENTICATED_LINKS:
            out.append(ep)
    if get("scouting/multicast/enabled"):
        out.append("multicast scouting")
    return out


def with_listen_endpoints(cfg: Mapping[str, Any], endpoints: list[str]) -> dict[str, Any]:
    return merge(cfg, {"listen": {"endpoints": list(endpoints)}})


def _tcp_parts(endpoint: str) -> tuple[str, str, int, str] | None:
    m = _TCP_RE.match(endpoint)
    if m is None:
        return None
    return m["proto"], m["host"].strip("[]"), int(m["port"]), m["rest"] or ""


def endpoint_in_use(endpoint: str) -> bool:
    """True when a TCP/TLS endpoint's address:port cannot be bound (someone holds it)."""
    parts = _tcp_parts(endpoint)
    if parts is None or parts[2] == 0:
        return False
    _, host, port, _ = parts
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        try:
            s.bind((host, port))
        except OSError:
            return True
    return False


def free_port_endpoint(endpoint: str) -> str:
    """The same endpoint on a port the OS says is free now."""
    parts = _tcp_parts(endpoint)
    if parts is None:
        return endpoint
    proto, host, _, rest = parts
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        port = s.getsockname()[1]
    shown = f"[{host}]" if family == socket.AF_INET6 else host
    return f"{proto}/{shown}:{port}{rest}"


def check_key_prefix(prefix: str) -> str:
    """A key prefix must be a concrete key (no wildcards, no empty chunks)."""
    if not prefix or prefix.startswith("/") or prefix.endswith("/") or "//" in prefix:
        raise ValueError(f"key prefix {prefix!r}: no leading, trailing or double '/'")
    if _WILD_RE.search(prefix):
        raise ValueError(f"key prefix {prefix!r}: no wildcard characters (* $ ? #)")
    return prefix
