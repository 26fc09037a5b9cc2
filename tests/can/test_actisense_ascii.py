"""Actisense N2K ASCII lines (`A<timer> <SSDDP> <PGN> <hex>`): decoding, rejects, and
agreement with the `nmea2000` package's writer of the format."""

from __future__ import annotations

import pytest

from edged.records import RawRecord
from edged_can.formats import Message, actisense_ascii
from edged_can.plugin import CanInput

HDG = bytes.fromhex("ff103bff7fcef5fc")  # 127250: heading 1.5120 rad, true


def _decode(lines: list[bytes], make_health):
    health = make_health("ngx")
    dec = CanInput.make_decoder("ngx", None, health)
    out = []
    for i, ln in enumerate(lines):
        out.extend(dec.decode(RawRecord("can", "ngx", 1_700_000_000.0 + i, ln, {"format": "actisense_ascii"})))
    return out, health


def test_a_line_is_a_whole_message_with_source_destination_and_priority():
    # 07FF2: source 0x07, destination 0xFF, priority 2; 1F112 = 127250
    assert actisense_ascii.frame(b"A173321.107 07FF2 1F112 FF103BFF7FCEF5FC\r") == [Message(2, 127250, 7, 255, HDG)]
    assert actisense_ascii.frame(b"07FF2 1F112 FF103BFF7FCEF5FC") == [Message(2, 127250, 7, 255, HDG)]


def test_the_nmea2000_packages_writer_is_read_as_the_bus_frame(make_health):
    import nmea2000.decoder as nm  # a pinned dependency (pyproject.toml): no skip
    from nmea2000.encoder_formats import N2kAsciiEncoder

    msg = nm.NMEA2000Decoder().decode("2024-01-01T12:00:00.000Z,2,127250,7,255,8,ff,10,3b,ff,7f,ce,f5,fc")
    line = N2kAsciiEncoder().encode(msg).encode()
    ms, health = _decode([line], make_health)
    assert [(m.kind, m.source) for m in ms] == [("heading", "ngx.7")]
    assert ms[0].values["heading"] == pytest.approx(1.5120)
    assert health.counters["messages"] == 1


BAD = [
    (b"A173321.107 07FF2 1F112 FF103BFF7FCEF5F", "rejected.bad_length"),  # odd digits
    (b"A173321.107 07FF2 1F112", "rejected.bad_line"),  # no data
    (b"A173321.107 07FF2 7FFFFF FF103BFF7FCEF5FC", "rejected.bad_pgn"),
    (b"A173321.107 07FF9 1F112 FF103BFF7FCEF5FC", "rejected.bad_line"),  # priority 9
    (b"A173321.107 07FF2 1F112 " + b"00" * 224, "rejected.bad_length"),
    (b"$PCDIN,01F119,00000000,0F,2AAF00D1067414FF*59", "rejected.bad_line"),
]


@pytest.mark.parametrize("line,counter", BAD)
def test_bad_lines_are_counted_by_reason_and_the_next_is_decoded(make_health, line, counter):
    ms, health = _decode([line, b"A173321.207 07FF2 1F112 FF103BFF7FCEF5FC"], make_health)
    assert health.counters[counter] == 1
    assert [m.kind for m in ms] == ["heading"]
