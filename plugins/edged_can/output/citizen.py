"""What makes the output a proper NMEA 2000 bus citizen (the `can` transport).

- Address claim (ISO 11783-5, PGN 60928) with our NAME: at start the bus is asked for
  its claims (a request for 60928), then the preferred address, or the next free one,
  is claimed; 250 ms later it is ours. A device claiming our address with a higher
  priority (numerically lower) NAME takes it: we claim another free address and send
  from that one (`address_lost`, then `address_claims`); one with a lower priority
  NAME is answered with our claim again. Until an address is ours, nothing but claims
  is sent (`unsent.no_address`).
- ISO Requests (PGN 59904), to everyone or to us: 60928 (our claim again), 126996
  Product Information (model "edged", our version), 126993 (a heartbeat), 126464 (the
  PGNs we send and receive); any other PGN asked of us alone is refused with a NAK
  (59392). Each answer counts `requests_answered`.
- A heartbeat (PGN 126993) every `heartbeat` seconds of clock time, and at once
  from each address newly ours.

Time is the clock's (`Clock.monotonic`, in ms for the claim state machine): a test
moves it by hand, a replay by the data.
"""

from __future__ import annotations

import importlib.metadata
from typing import Any, Callable

from edged.health import ComponentHealth

from . import wire
from .config import Nmea2000OutputConfig
from .wire import Frame

__all__ = ["Citizen", "name_of", "software_version", "PGN_CLAIM", "PGN_REQUEST"]

PGN_CLAIM = 60928
PGN_REQUEST = 59904
PGN_PRODUCT = 126996
PGN_HEARTBEAT = 126993
PGN_LIST = 126464
PGN_ACK = 59392
GLOBAL = 255


def name_of(config: Nmea2000OutputConfig) -> int:
    """Our 64-bit ISO NAME from the configuration's fields."""
    return wire.iso_name(
        unique_number=config.unique_number, manufacturer_code=config.manufacturer_code,
        device_function=config.device_function, device_class=config.device_class,
        device_instance=config.device_instance, system_instance=config.system_instance,
        industry_group=config.industry_group)


def software_version() -> str:
    """edged's version (the package's `__version__`, else its metadata)."""
    import edged

    v = getattr(edged, "__version__", None)
    if isinstance(v, str) and v:
        return v
    try:
        return importlib.metadata.version("edged")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


#: Seconds (of clock time) between two answers to one requester for one PGN.
ANSWER_INTERVAL = 1.0

class Citizen:
    """Claims and keeps an address, answers requests, beats; `send(frame)` puts a
    frame on the bus as it is (its own source address)."""

    def __init__(self, config: Nmea2000OutputConfig, health: ComponentHealth,
                 send: Callable[[Frame], Any], transmits: tuple[int, ...]) -> None:
        self.config = config
        self.name = name_of(config)
        self._health = health
        self._send = send
        self._claimer = wire.claimer(self.name, config.address)
        self._transmits = tuple(sorted({*transmits, PGN_CLAIM, PGN_PRODUCT, PGN_HEARTBEAT, PGN_LIST, PGN_ACK}))
        self._beats = 0
        self._next_beat: float | None = None
        self._beat_from: int | None = None
        self._version = software_version()
        #: (requester, PGN) -> when it was last answered (clock s): a flood of requests
        #: gets one answer a second, not a bus full of product information.
        self._answered: dict[tuple[int, int], float] = {}
        self._info()

    @property
    def address(self) -> int | None:
        """The address we may send from now; None while none is ours."""
        return self._claimer.send_address

    def _info(self) -> None:
        info = self._health.info
        info["address"] = self._claimer.send_address
        info["address_state"] = self._claimer.state

    def _out(self, frames: list[Any]) -> None:
        for f in frames:
            frame = Frame(*f)
            if frame.pgn == PGN_CLAIM:
                self._health.count("address_claims")
            self._send(frame)
        self._info()

    def start(self, now: float) -> None:
        """Begin: ask the bus for its claims, then claim (`tick` goes on)."""
        self._claimer = wire.claimer(self.name, self.config.address)
        self._next_beat = None
        self._out(self._claimer.start(_ms(now)))

    def tick(self, now: float) -> None:
        """Advance the claim's deadlines; send the heartbeat when due."""
        self._out(self._claimer.tick(_ms(now)))
        addr = self.address
        every = self.config.heartbeat
        if addr is None or every <= 0:
            return
        if self._next_beat is None or now >= self._next_beat or addr != self._beat_from:
            # at once from a new address: listeners learn where we went
            self._next_beat, self._beat_from = now + every, addr
            self._send(wire.heartbeat(addr, self._beats, every))
            self._beats += 1
            self._health.count("heartbeats")

    def on_frame(self, now: float, pgn: int, src: int, dst: int, data: bytes) -> None:
        """A frame another device sent: claims and requests matter."""
        if pgn == PGN_CLAIM and len(data) >= 8:
            before = self.address
            self._out(self._claimer.on_address_claim(_ms(now), src, int.from_bytes(data[:8], "little")))
            if before is not None and self.address != before:
                self._health.count("address_lost")
                self._health.error(f"address {before} taken by a device with a higher priority NAME "
                                   f"(from {src}); claiming another")
        elif pgn == PGN_REQUEST and len(data) >= 3:
            addr = self.address
            if dst == GLOBAL or (addr is not None and dst == addr):
                pgn = data[0] | data[1] << 8 | data[2] << 16
                if pgn != PGN_CLAIM and self._too_soon(now, src, pgn):
                    return
                self._request(src, dst, pgn)

    def _too_soon(self, now: float, src: int, pgn: int) -> bool:
        """Whether `src` asked for `pgn` less than ANSWER_INTERVAL ago (counted
        `rejected.request_flood`); a claim request is always answered (one frame)."""
        last = self._answered.get((src, pgn))
        if last is not None and 0.0 <= now - last < ANSWER_INTERVAL:
            self._health.count("rejected.request_flood")
            return True
        if len(self._answered) >= 1024:  # requesters come and go: forget them all
            self._answered.clear()
        self._answered[(src, pgn)] = now
        return False

    def _request(self, src: int, dst: int, pgn: int) -> None:
        addr = self.address
        if pgn == PGN_CLAIM:
            answer = self._claimer.respond_to_claim_request()
            frames = [] if answer is None else [Frame(*answer)]
        elif addr is None:
            self._health.count("unsent.no_address")
            return
        elif pgn == PGN_PRODUCT:
            c = self.config
            frames = [wire.product_information(addr, model_id="edged", software_version=self._version,
                                               model_version=c.model_version, serial=c.serial,
                                               product_code=c.product_code)]
        elif pgn == PGN_HEARTBEAT and self.config.heartbeat > 0:
            frames = [wire.heartbeat(addr, self._beats, self.config.heartbeat)]
            self._beats += 1
        elif pgn == PGN_LIST:
            frames = wire.pgn_list(addr, src, self._transmits, (PGN_REQUEST, PGN_CLAIM))
        elif dst != GLOBAL:
            frames = [wire.nak(addr, src, pgn)]
        else:
            return  # a request to everyone for what we do not send: not ours to answer
        for f in frames:
            if f.pgn == PGN_CLAIM:
                self._health.count("address_claims")
            self._send(f)
        if frames:
            self._health.count("requests_answered")
        self._info()


def _ms(now: float) -> int:
    return int(round(now * 1000.0))
