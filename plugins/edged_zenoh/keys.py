"""The key space and JSON payloads of DESIGN §6, in one place.

`KeySpace` spells every key under the vessel's prefix; `payload_of` turns a record into
the JSON object published for it, through a table keyed by record type (no per-
estimator code: an estimate named `foo` becomes `est/foo` with `{"t", **values}`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Callable

from edged import jsonpayload
from edged.records import Estimate, HealthRecord, Measurement, measurement_to_json

__all__ = ["KeySpace", "PAYLOADS", "payload_of", "encode", "valid_chunk"]

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


def _estimate_json(e: Estimate) -> dict[str, Any]:
    out: dict[str, Any] = {"t": e.t}
    out.update(e.values)
    return out


def _health_json(h: HealthRecord) -> dict[str, Any]:
    return h.values


#: Record type -> its JSON object. Raw records have no entry: they are not published.
PAYLOADS: dict[type, Callable[[Any], dict[str, Any]]] = {
    Measurement: measurement_to_json,
    Estimate: _estimate_json,
    HealthRecord: _health_json,
}


def payload_of(rec: Any) -> dict[str, Any]:
    return PAYLOADS[type(rec)](rec)


def encode(obj: dict[str, Any]) -> tuple[bytes, bool]:
    """Compact JSON bytes of `obj`, and whether non-finite numbers had to become null
    (the one encoder of every output, `edged.jsonpayload`)."""
    return jsonpayload.dumps(obj)
