"""The key space and JSON payloads of DESIGN §6, in one place.

`KeySpace` spells every key under the vessel's prefix; `payload_of` turns a record into
the JSON object published for it, through the core's one table keyed by record type
(`edged.jsonpayload.record_json`: no per-estimator code, the same JSON as recorded).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Callable

from edged import jsonpayload

__all__ = ["KeySpace", "payload_of", "encode", "valid_chunk"]

_BAD_CHUNK = re.compile(r"[*$?#/\s]")


def valid_chunk(name: str) -> bool:
    """A name usable as one key chunk: not empty, no wildcard nor separator."""
    return bool(name) and _BAD_CHUNK.search(name) is None


@dataclass(frozen=True)
class KeySpace:
    """Keys under `prefix` (default `vessel/<vessel_id>`)."""

    prefix: str

    @property
    def everything(self) -> str:
        return self.prefix + "/**"

    @property
    def health(self) -> str:
        return self.prefix + "/health"

    @property
    def alive(self) -> str:
        return self.prefix + "/alive"

    @property
    def env_current(self) -> str:
        return self.prefix + "/env/current"

    def est(self, name: str) -> str:
        return f"{self.prefix}/est/{name}"

    def meas(self, kind: str, source: str) -> str:
        return f"{self.prefix}/meas/{kind}/{source}"


#: Record type -> its JSON object, the core's one mapping (the same JSON as MCAP's).
#: Raw records have no entry: they are not published.
payload_of: Callable[[Any], dict[str, Any]] = jsonpayload.record_json


def encode(obj: dict[str, Any]) -> tuple[bytes, bool]:
    """Compact JSON bytes of `obj`, and whether non-finite numbers had to become null
    (the one encoder of every output, `edged.jsonpayload`)."""
    return jsonpayload.dumps(obj)
