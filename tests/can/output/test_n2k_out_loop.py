"""No loops: the frames of our NMEA 2000 output, fed into the CAN input's decoder with
the output's own marks, give no measurement and count `rejected.own_output`; the same
frames without the marks give measurements. The decoder knows our address only from
our address claim, and gives it back when another NAME claims it."""

from __future__ import annotations

from typing import Any

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import NO_MARKS, own_marks_of
from edged.records import RawRecord
from edged_can.config import CanConfig
from edged_can.decoder import CanDecoder
from edged_can.formats import can_id
from edged_can.output.config import Nmea2000OutputConfig
from edged_can.output.marks import OWN_GATEWAY_TX, OWN_NAME, name_hex, parse_names, parse_pgns
from edged_can.output.plugin import Nmea2000Output

from .conftest import T0, man_est, stw_est, split


def raw(msg: Any, t: float = T0) -> RawRecord:
    return RawRecord("can", "can0", t, bytes(msg.data), {"id": msg.arbitration_id, "ext": True})


def decoder(own: Any = NO_MARKS) -> tuple[CanDecoder, ComponentHealth]:
    health = ComponentHealth("can0", "input", "can", ManualClock(T0))
    return CanDecoder("can0", CanConfig(type="can"), health, own), health


async def our_frames(make_rig: Any) -> tuple[list[Any], Any]:
    rig = await make_rig()
    addr = await rig.claimed()
    rig.out.write([stw_est(T0 + 10.0)])
    rig.out.write([man_est(T0 + 11.0)])
    await rig.peer.messages({128259, 130577, 127250, 127251, 128000, 129026}, src=addr)
    return list(rig.peer.frames), rig


async def test_our_output_looped_into_the_can_input_gives_no_measurement(make_rig: Any) -> None:
    frames, rig = await our_frames(make_rig)
    assert any(split(f.arbitration_id)[1] == 60928 for f in frames)  # the decoder learns from it

    plain, plain_health = decoder()
    measured = [m for f in frames for m in plain.decode(raw(f))]
    assert {m.kind for m in measured} >= {"heading", "yaw_rate", "water_speed", "velocity_ground"}
    assert "rejected.own_output" not in plain_health.counters

    marks = own_marks_of([(Nmea2000Output, rig.out.config)])
    guarded, health = decoder(marks)
    assert [m for f in frames for m in guarded.decode(raw(f))] == []
    data_frames = [f for f in frames if split(f.arbitration_id)[1] != 59904]  # sent from 254
    assert health.counters["rejected.own_output"] == len(data_frames)


def test_an_address_claimed_by_another_name_is_decoded_again() -> None:
    ours = 0xC0788C00E7E04312
    dec, health = decoder({OWN_NAME: frozenset({name_hex(ours)})})
    heading = bytes.fromhex("001027ff7fff7ffc")  # 1.0 rad true

    def frame(pgn: int, src: int, data: bytes) -> RawRecord:
        return RawRecord("can", "can0", T0, data, {"id": can_id(2, pgn, src, 255), "ext": True})

    assert dec.decode(frame(127250, 40, heading))  # nobody claimed 40 yet: not ours
    assert dec.decode(frame(60928, 40, ours.to_bytes(8, "little"))) == []
    assert dec.decode(frame(127250, 40, heading)) == []
    assert dec.decode(frame(127250, 41, heading))  # another address
    dec.decode(frame(60928, 40, (ours - 5).to_bytes(8, "little")))  # 40 now belongs to another device
    assert dec.decode(frame(127250, 40, heading))
    assert health.counters["rejected.own_output"] == 2


def _bst93(prio: int, pgn: int, dst: int, src: int, data: bytes) -> bytes:
    body = bytes([0x93, 11 + len(data), prio]) + pgn.to_bytes(3, "little") + bytes([dst, src]) + bytes(4)
    body += bytes([len(data)]) + data
    body += bytes([(-sum(body)) & 0xFF])
    return b"\x10\x02" + body.replace(b"\x10", b"\x10\x10") + b"\x10\x03"


def test_whole_messages_of_a_gateway_from_our_address_are_refused() -> None:
    ours = 0xC0788C00E7E04312
    dec, health = decoder({OWN_NAME: frozenset({name_hex(ours)})})

    def rec(pgn: int, src: int, data: bytes) -> RawRecord:
        return RawRecord("can", "ngt", T0, _bst93(2, pgn, 255, src, data), {"format": "actisense_bst"})

    heading = bytes.fromhex("001027ff7fff7ffc")
    assert dec.decode(rec(60928, 50, ours.to_bytes(8, "little"))) == []
    assert dec.decode(rec(127250, 50, heading)) == []
    assert dec.decode(rec(127250, 51, heading))
    assert health.counters["rejected.own_output"] == 2


def test_marks_that_are_no_name_are_left_out() -> None:
    assert parse_names(frozenset({"c0788c00e7e04312", "not hex", "1" * 17})) == frozenset({0xC0788C00E7E04312})
    assert parse_names("c0788c00e7e04312") == frozenset()  # a mark's values are a set, not a string


def test_a_ydwg_echo_of_what_we_send_through_it_is_refused() -> None:
    """Through a YDWG the frames carry the gateway's address and NAME; it echoes them to
    its readers as `T` lines. The output's marks name the PGNs it sends through it: a
    `T` line of one of them is edged's own, an `R` line (another device) is not."""
    cfg = Nmea2000OutputConfig(type="nmea2000", transport="ydwg", host="127.0.0.1", rates={"128000": 0})
    marks = own_marks_of([(Nmea2000Output, cfg)])
    assert marks[OWN_GATEWAY_TX] == frozenset({"128259", "130577", "127250", "127251", "129026"})
    assert OWN_GATEWAY_TX not in Nmea2000Output.own_marks(Nmea2000OutputConfig(type="nmea2000"))  # on a bus
    dec, health = decoder(marks)

    def line(direction: str, pgn: int) -> RawRecord:
        ident = can_id(2, pgn, 3, 255)
        return RawRecord("can", "ydwg", T0, f"12:00:00.000 {direction} {ident:08X} 00 10 27 FF 7F FF 7F FC".encode(),
                         {"format": "ydwg_raw"})

    assert dec.decode(line("T", 127250)) == []  # our heading, echoed
    assert [m.kind for m in dec.decode(line("R", 127250))] == ["heading"]  # a compass's
    assert health.counters["rejected.own_output"] == 1 and health.counters["frames.tx"] == 1
    plain, _ = decoder()
    assert [m.kind for m in plain.decode(line("T", 127250))] == ["heading"]  # no output: read
    assert parse_pgns(frozenset({"127250", "x", str(1 << 18)})) == frozenset({127250})
