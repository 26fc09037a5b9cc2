"""Stable source names for NMEA 2000 devices.

An N2K address is not an identity: devices renegotiate addresses at power-up. The
ISO NAME a device claims its address with (PGN 60928) is. A configured NAME therefore
wins over a configured address, so that two gyros swapping addresses do not swap
their measurements' sources; without configuration the name is `<bus>.<address>`.
"""

from __future__ import annotations

from typing import Mapping

from edged.health import ComponentHealth


class N2kSources:
    def __init__(
        self,
        bus: str,
        by_address: Mapping[int, str],
        by_iso_name: Mapping[int, str],
        health: ComponentHealth,
    ) -> None:
        self._bus = bus
        self._by_address = dict(by_address)
        self._by_iso_name = dict(by_iso_name)
        self._health = health
        self._claims: dict[int, int] = {}  # address -> ISO NAME
        self._cache: dict[int, str] = {}

    def name(self, address: int) -> str:
        s = self._cache.get(address)
        if s is None:
            s = self._resolve(address)
            self._cache[address] = s
        return s

    def _resolve(self, address: int) -> str:
        iso = self._claims.get(address)
        if iso is not None and iso in self._by_iso_name:
            return self._by_iso_name[iso]
        return self._by_address.get(address) or f"{self._bus}.{address}"

    def claim(self, address: int, iso_name: int) -> None:
        """An address claim: `address` now belongs to the device called `iso_name`."""
        if self._claims.get(address) == iso_name:
            return
        moved = [a for a, n in self._claims.items() if n == iso_name and a != address]
        for a in moved:
            del self._claims[a]
        self._claims[address] = iso_name
        self._cache.clear()
        if iso_name in self._by_iso_name:
            self._health.info.setdefault("n2k_addresses", {})[self._by_iso_name[iso_name]] = address
