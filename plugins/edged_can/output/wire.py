"""The NMEA 2000 output's adapter over the `nmea2000` package: what goes on the wire.

Why the package: the field layouts, resolutions and "no data" codes of the PGNs we
send are canboat's, and so are its ISO NAME packing, the address-claim state machine
(ISO 11783-5), and the product information and heartbeat layouts; writing them again
would be a second copy of the same knowledge. Why an adapter: only this module of the
output imports the package, so that a change of library touches one file, and every
frame leaves as one `Frame` tuple whatever made it.

The package's encoders are checked by the tests against its decoder *and* against the
standard's layouts written out by hand (`tests/can/output/test_pgns.py`): each PGN we
send is encoded here, none needed an encoder of our own.
"""

from __future__ import annotations

from typing import Any, Mapping, NamedTuple

from nmea2000 import _canboat as canboat

from ..formats import can_id

__all__ = ["Frame", "EncodeError", "encode", "is_fast", "fragment", "iso_name", "claimer",
           "product_information", "heartbeat", "pgn_list", "ngt1", "nak", "identifier"]

#: canboat's PGN definitions in SI units (rad, m/s, s): edged's units.
_DB = canboat.Database("si")
EncodeError = canboat.EncodeError
#: Fast-packet payloads are at most 223 bytes (6 + 31 × 7).
MAX_FAST = 223


class Frame(NamedTuple):
    """One whole message to send: priority, PGN, source, destination, payload."""

    prio: int
    pgn: int
    src: int
    dst: int
    payload: bytes


def _pgn_id(pgn: int) -> str:
    variants = _DB.pgn_variants(pgn)
    if not variants:
        raise KeyError(f"canboat does not know PGN {pgn}")
    return variants[0].id


def encode(pgn: int, fields: Mapping[str, Any]) -> bytes:
    """The payload of `pgn` with `fields` (canboat field ids, SI units); a field that is
    None or left out goes out as its "no data" code, reserved bits as ones.
    Raises `EncodeError` for a value outside the field's range."""
    return _DB.encode(_pgn_id(pgn), {k: v for k, v in fields.items() if v is not None})


def is_fast(pgn: int) -> bool:
    """Whether `pgn` travels as a fast-packet (130577, 126996)."""
    variants = _DB.pgn_variants(pgn)
    return bool(variants) and variants[0].packet_type == "Fast"


def fragment(seq: int, payload: bytes) -> list[bytes]:
    """The CAN frames of a fast-packet message with sequence counter `seq` (0-7)."""
    return canboat.fast_packet_fragment(seq & 7, payload)


def identifier(frame: Frame, src: int | None = None) -> int:
    """The 29-bit CAN identifier of a frame (with `src` instead of its own, if given)."""
    return can_id(frame.prio, frame.pgn, frame.src if src is None else src, frame.dst)


def iso_name(*, unique_number: int, manufacturer_code: int, device_function: int, device_class: int,
             device_instance: int, system_instance: int, industry_group: int) -> int:
    """The 64-bit ISO NAME of those fields (always arbitrary-address capable)."""
    return canboat.iso_name(manufacturer_code, unique_number, device_function=device_function,
                            device_class=device_class, device_instance=device_instance,
                            system_instance=system_instance, industry_group=industry_group,
                            arbitrary_address_capable=True)


def claimer(name: int, preferred: int) -> Any:
    """The ISO 11783-5 address-claim state machine for `name` (canboat's
    `AddressClaimer`: `start`, `tick`, `on_address_claim` in ms, each returning the
    frames to send; `address`, `send_address`, `state`)."""
    return canboat.AddressClaimer(name, preferred, True)


def product_information(src: int, *, model_id: str, software_version: str, model_version: str,
                        serial: str, product_code: int) -> Frame:
    """PGN 126996 (NMEA 2000 version 2.100, certification level A, LEN 1)."""
    return Frame(*canboat.product_information_frame(
        src, nmea2000_version=2100, product_code=product_code, model_id=model_id,
        software_version=software_version, model_version=model_version, model_serial=serial,
        certification_level=0, load_equivalency=1))


def heartbeat(src: int, sequence: int, interval: float) -> Frame:
    """PGN 126993 advertising `interval` seconds (at most 65.532)."""
    return Frame(*canboat.heartbeat_frame(src, sequence % 253, round(interval * 1000)))


def pgn_list(src: int, dst: int, transmit: tuple[int, ...], receive: tuple[int, ...]) -> list[Frame]:
    """PGN 126464: the PGNs we transmit and those we receive, to `dst` (fast-packet)."""
    return [Frame(*f) for f in canboat.pgn_list_frames(src, dst, list(transmit), list(receive))]


def ngt1() -> Any:
    """The Actisense NGT-1 byte protocol (canboat's `GatewayCodec("ngt1")`), of which
    the output uses `send(pgn, data, src, dst, prio)`: one framed BST 94 message."""
    return canboat.GatewayCodec("ngt1")


def nak(src: int, dst: int, pgn: int) -> Frame:
    """PGN 59392 ISO Acknowledgement "NAK" for a request of a PGN we do not answer."""
    return Frame(*canboat.iso_ack_frame(src, dst, 1, pgn))
