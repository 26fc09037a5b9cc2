"""Actisense BST binary (NGT-1 0x93, NGX/PRO-NDC BST-D0 and BST-95): framing, decoding,
rejects, and agreement with an independent writer and reader of the format (the
`nmea2000` package's BST encoders and its canboat NGT-1 codec).

Messages are built by hand here from the layouts in formats/actisense_bst.py's
docstring (Actisense's BST-93/D0/95 documents), so the reader is checked against
the wire format, not against itself.
"""

from __future__ import annotations

import pytest

from edged.records import RawRecord
from edged_can.formats import Bad, Frame, Message, actisense_bst, can_id
from edged_can.formats.actisense_bst import Deframer, frame, parse, unstuff
from edged_can.plugin import CanInput


# 127250 Vessel Heading from 7: SID 0xFF, heading 0x3B10 = 15120 × 1e-4 = 1.5120 rad,
# deviation n/a, variation 0xF5CE = -2610 × 1e-4 rad, reference true (0xFC).
HDG = bytes.fromhex("ff103bff7fcef5fc")


def _ck(body: bytes) -> bytes:
    return body + bytes([(-sum(body)) & 0xFF])


def stuff(msg: bytes) -> bytes:
    """DLE STX <msg with each DLE doubled> DLE ETX: what goes over the wire."""
    return b"\x10\x02" + msg.replace(b"\x10", b"\x10\x10") + b"\x10\x03"


def bst93(pgn: int, src: int, data: bytes, prio: int = 2, dst: int = 255, timer: int = 123456) -> bytes:
    body = bytes([prio]) + pgn.to_bytes(3, "little") + bytes([dst, src]) + timer.to_bytes(4, "little") + bytes([len(data)]) + data
    return _ck(bytes([0x93, len(body)]) + body)


def bst_d0(pgn: int, src: int, data: bytes, prio: int = 2, dst: int = 255) -> bytes:
    pf, ps = (pgn >> 8) & 0xFF, (pgn & 0xFF) if ((pgn >> 8) & 0xFF) >= 240 else dst
    length = 13 + len(data)
    head = bytes([0xD0, length & 0xFF, length >> 8, dst, src, ps, pf, (prio << 2) | (pgn >> 16), 0]) + bytes(4)
    return _ck(head + data)


def bst95(ident: int, data: bytes) -> bytes:
    prio, pgn_dp, pf, ps, src = ident >> 26, (ident >> 24) & 3, (ident >> 16) & 0xFF, (ident >> 8) & 0xFF, ident & 0xFF
    return _ck(bytes([0x95, 6 + len(data), 0x34, 0x12, src, ps, pf, (prio << 2) | pgn_dp]) + data)


def _decode(records: list[bytes], make_health, source: str = "ngt"):
    health = make_health(source)
    dec = CanInput.make_decoder(source, None, health)
    out = []
    for i, data in enumerate(records):
        out.extend(dec.decode(RawRecord("can", source, 1_700_000_000.0 + i, data, {"format": "actisense_bst"})))
    return out, health


# ---- decoding -------------------------------------------------------------------------


def test_ngt1_message_gives_the_heading_a_bus_frame_gives(make_health):
    ms, health = _decode([stuff(bst93(127250, 7, HDG))], make_health)
    assert [(m.kind, m.source) for m in ms] == [("heading", "ngt.7")]
    assert ms[0].values["heading"] == pytest.approx(1.5120)
    # the very same from a CAN bus
    bus = make_health("bus")
    ref = CanInput.make_decoder("ngt", None, bus).decode(
        RawRecord("can", "ngt", 1_700_000_000.0, HDG, {"id": can_id(2, 127250, 7, 255), "ext": True})
    )
    assert [(m.kind, m.source, m.values) for m in ms] == [(m.kind, m.source, m.values) for m in ref]
    assert health.counters["messages"] == 1


def test_a_dle_in_the_data_is_doubled_on_the_wire_and_read_back(make_health):
    data = bytes.fromhex("ff10101010f5fc00")  # heading 0x1010 and more DLE bytes
    wire = stuff(bst93(127250, 0x10, data))
    assert wire.count(b"\x10\x10") >= 3
    assert unstuff(wire)[:2] == b"\x93\x13"
    assert parse(unstuff(wire)) == Message(2, 127250, 0x10, 255, data)


def test_bst_d0_is_a_whole_message_and_bst95_a_frame_for_our_assembler(make_health, build):
    payload = build.pgn_129029(54.25, 7.5, days=19723, secs=43200.0)
    d0 = stuff(bst_d0(129029, 160, payload, prio=3))
    frames = build.fast_frames(payload, seq=2)
    b95 = [stuff(bst95(can_id(3, 129029, 160, 255), fr)) for fr in frames]
    assert parse(unstuff(d0)) == Message(3, 129029, 160, 255, payload)
    assert parse(unstuff(b95[0])) == Frame(can_id(3, 129029, 160, 255), frames[0])
    a, ha = _decode([d0], make_health, "a")
    b, hb = _decode(b95, make_health, "b")
    assert [m.kind for m in a] == [m.kind for m in b] and "position" in [m.kind for m in a]
    pos = [m for m in a if m.kind == "position"][0]
    assert (pos.values["lat"], pos.values["lon"]) == pytest.approx((54.25, 7.5), abs=1e-9)
    assert [m.values for m in a] == [m.values for m in b]


def test_pdu1_destination_survives_bst95(make_health):
    # 59904 ISO Request is PDU1: the PS byte is the destination, not part of the PGN
    ident = can_id(6, 59904, 5, 0x23)
    assert parse(unstuff(stuff(bst95(ident, b"\x14\xf0\x01")))) == Frame(ident, b"\x14\xf0\x01")


# ---- an independent writer and reader ---------------------------------------------------


def test_the_nmea2000_packages_bst_encoders_are_read_as_the_bus_frame():
    import nmea2000.decoder as nm  # a pinned dependency (pyproject.toml): no skip
    from nmea2000.encoder_formats import Bst95Encoder, BstD0Encoder

    msg = nm.NMEA2000Decoder().decode("2024-01-01T12:00:00.000Z,2,127250,7,255,8,ff,10,3b,ff,7f,ce,f5,fc")
    (d0,) = BstD0Encoder().encode(msg)
    (b95,) = Bst95Encoder().encode(msg)
    assert frame(stuff(d0)) == [Message(2, 127250, 7, 255, HDG)]
    assert frame(stuff(b95)) == [Frame(can_id(2, 127250, 7, 255), HDG)]


def test_our_ngt1_messages_are_what_canboats_ngt1_codec_reads():
    from nmea2000 import _canboat as canboat  # a pinned dependency (pyproject.toml): no skip
    codec = canboat.GatewayCodec("ngt1")
    codec.open()
    events = codec.receive(stuff(bst93(127250, 0x10, HDG)) + stuff(bst93(128267, 35, bytes.fromhex("01e8030000000000"))), 0)
    assert events == [("frame", (2, 127250, 0x10, 255, HDG)), ("frame", (2, 128267, 35, 255, bytes.fromhex("01e8030000000000")))]


# ---- the stream: any split gives the same messages ----------------------------------------


def test_deframer_gives_the_same_messages_for_any_split(make_health):
    msgs = [stuff(bst93(127250, 7, HDG)), stuff(bst93(127250, 0x10, bytes.fromhex("ff101010f5fc0010"))),
            stuff(bst_d0(127250, 7, HDG))]
    wire = b"".join(msgs)
    for size in (1, 2, 3, 7, 64):
        health = make_health("s")
        d = Deframer(health)
        got = [m for i in range(0, len(wire), size) for m in d.feed(wire[i:i + size])]
        assert got == msgs, size
        assert "discarded_bytes" not in health.counters


def test_noise_before_and_between_messages_is_counted_not_decoded(make_health):
    health = make_health("s")
    d = Deframer(health)
    m = stuff(bst93(127250, 7, HDG))
    got = d.feed(b"\x00\xff\x03" + m + b"\x55\x55" + m)
    assert got == [m, m]
    assert health.counters["discarded_bytes"] == 5


def test_a_message_cut_by_a_new_start_or_the_end_is_counted_partial(make_health):
    health = make_health("s")
    d = Deframer(health)
    m = stuff(bst93(127250, 7, HDG))
    assert d.feed(m[:9] + m) == [m]
    assert health.counters["partial_messages"] == 1
    assert d.feed(m[:9]) == []
    d.end()
    assert health.counters["partial_messages"] == 2
    assert d.feed(m) == [m]  # the next connection starts clean


def test_a_message_without_end_is_too_long_and_the_stream_resynchronises(make_health):
    health = make_health("s")
    d = Deframer(health)
    m = stuff(bst93(127250, 7, HDG))
    assert d.feed(b"\x10\x02" + b"\x00" * (actisense_bst.MAX_FRAME + 10)) == []  # no end in sight
    assert health.counters["rejected.too_long"] == 1
    assert len(d.buf) <= actisense_bst.MAX_FRAME  # memory stays bounded
    assert d.feed(b"\x00" * 10 + m) == [m]


def test_a_bad_escape_is_rejected_and_the_next_message_read(make_health):
    health = make_health("s")
    d = Deframer(health)
    m = stuff(bst93(127250, 7, HDG))
    assert d.feed(b"\x10\x02\x93\x10\x07" + m) == [m]
    assert health.counters["rejected.bad_escape"] == 1


# ---- rejects: each reason counted, the next message decoded ---------------------------------

_GOOD = bst93(127250, 7, HDG)
BAD = [
    (stuff(_GOOD[:-1] + bytes([_GOOD[-1] ^ 1])), "rejected.checksum"),
    (stuff(_ck(bytes([0x93, 0x20]) + _GOOD[2:-1])), "rejected.bad_length"),  # says 32 bytes
    (stuff(_ck(_GOOD[:12] + bytes([9]) + _GOOD[13:-1])), "rejected.bad_length"),  # n = 9 for 8
    (stuff(_ck(bytes([0x95, 6 + 9, 0, 0, 7, 0x12, 0xF1, 9]) + bytes(9))), "rejected.bad_length"),  # 9-byte frame
    (stuff(_ck(bytes([0xD0, 0x30, 0x00]) + bytes(12))), "rejected.bad_length"),
    (stuff(_ck(bytes([0x93, 12, 2, 0x12, 0xF1, 0xFF, 255, 7, 0, 0, 0, 0, 1, 0]))), "rejected.bad_pgn"),
    (stuff(_ck(bytes([0x42, 1, 0]))), "rejected.unknown_bst"),
    (stuff(b"\x93"), "rejected.bad_length"),
    (b"\x10\x02\x93\x10\x07\x10\x03", "rejected.bad_escape"),  # a recorded raw record, say
    (b"\x93\x00\x6d", "rejected.bad_frame"),  # no DLE STX / DLE ETX
]


@pytest.mark.parametrize("data,counter", BAD)
def test_bad_messages_are_counted_by_reason_and_the_next_is_decoded(make_health, data, counter):
    ms, health = _decode([data, stuff(_GOOD)], make_health)
    assert health.counters[counter] == 1
    assert [m.kind for m in ms] == ["heading"]


def test_the_gateways_own_messages_are_counted_not_rejected(make_health):
    answer = stuff(_ck(bytes([0xA0, 3, 0x11, 0x02, 0x00])))  # an answer to "receive all"
    command = stuff(_ck(bytes([0xA1, 3, 0x11, 0x02, 0x00])))  # the command, echoed
    ms, health = _decode([answer, command, stuff(_GOOD)], make_health)
    assert health.counters["gateway_messages"] == 1 and health.counters["gateway_tx"] == 1
    assert not [k for k in health.counters if k.startswith("rejected.")]
    assert [m.kind for m in ms] == ["heading"]


def test_parse_raises_bad_only():
    with pytest.raises(Bad):
        parse(b"")
