"""Framing: line ends, every reject path, TAG blocks, epoch prefixes, checksum policy."""

from __future__ import annotations

import pytest

from edged_nmea0183.framer import Framer
from edged_nmea0183.lines import MAX_LINE, Framed, LineSplitter, frame, nmea_checksum

HDT = "$HEHDT,274.07,T*19"


def test_checksum_matches_nmea_definition(nmea):
    assert frame(HDT.encode()) == Framed(HDT.encode(), None, None)
    assert nmea_checksum(b"HEHDT,274.07,T") == 0x19
    assert nmea("HEHDT,274.07,T") == HDT


def _tag(text: str) -> str:
    from functools import reduce
    from operator import xor

    return "\\%s*%02X\\" % (text, reduce(xor, text.encode(), 0))


@pytest.mark.parametrize(
    "line, reason",
    [
        ("$" + "A" * (MAX_LINE + 1), "too_long"),
        ("$GPHDT,12°,T*00", "non_ascii"),
        ('{"class":"VERSION","release":"3.24"}', "no_start"),
        ("GPHDT,274.07,T*19", "no_start"),
        ("$", "no_start"),
        ("$HEHDT,274.07,T", "no_checksum"),
        ("$HEHDT,274.07,T*1C", "checksum"),
        ("$HEHDT,274.07,T*G1", "checksum"),
        ("$HEHDT,274.07,T*", "checksum"),
        ("\\c:1700000000*00$HEHDT,274.07,T*19", "bad_tag"),  # TAG block never closed
        ("\\c:1700000000*00\\" + HDT, "tag_checksum"),
        ("\\c:1700000000\\" + HDT, "tag_checksum"),  # policy require: the tag needs *hh
        (_tag("c:soon") + HDT, "bad_timestamp"),
        (_tag("c:-5") + HDT, "bad_timestamp"),
        ("17000x0000 " + HDT, "bad_timestamp"),
        ("1700000000 HEHDT,274.07,T*19", "no_start"),
        (_tag("c:1700000000") + "garbage", "no_start"),
    ],
)
def test_reject_paths(line, reason):
    assert frame(line.encode("utf-8")) == reason


def test_comment_and_blank_lines():
    assert frame(b"# Name: B&G Zeus\xc2\xb2 9") == "comment"  # non-ASCII comments stay comments
    assert frame(b"") is None
    assert frame(b"   ") is None


def test_checksum_policies():
    missing = b"$HEHDT,274.07,T"
    wrong = b"$HEHDT,274.07,T*00"
    assert frame(missing, "allow-missing") == Framed(missing, None, None)
    assert frame(wrong, "allow-missing") == "checksum"
    assert frame(missing, "ignore") == Framed(missing, None, None)
    assert frame(wrong, "ignore") == Framed(wrong, None, None)


def test_tag_block_time_and_fields_kept(nmea):
    tag = nmea("s:r3669961,c:1700000000.5", "")  # NMEA 4.10: checksum over the tag text
    fr = frame(f"\\{tag}\\{HDT}".encode())
    assert isinstance(fr, Framed)
    assert fr.sentence == HDT.encode()
    assert fr.t_log == 1700000000.5
    assert fr.tag == tag  # other fields (the source `s:`) are kept for the raw record


def test_tag_time_in_milliseconds(nmea):
    fr = frame(("\\%s\\%s" % (nmea("c:1700000000123", ""), HDT)).encode())
    assert fr.t_log == pytest.approx(1700000000.123)


def test_epoch_prefix():
    fr = frame(b"1700000000.25 " + HDT.encode())
    assert fr == Framed(HDT.encode(), None, 1700000000.25)


@pytest.mark.parametrize("sep", [b"\r\n", b"\n", b"\r", b"\n\r"])
def test_splitter_line_ends_across_chunks(sep):
    data = sep.join([b"$A*00", b"$BB*00", b"$CCC*00"]) + sep
    s = LineSplitter()
    got: list[bytes] = []
    for i in range(len(data)):  # one byte at a time: every split point
        got += s.feed(data[i : i + 1])
    got += s.flush()
    assert [g for g in got if g] == [b"$A*00", b"$BB*00", b"$CCC*00"]


def test_splitter_bounds_a_stream_without_line_ends(health):
    f = Framer(health)
    out = f.feed(b"$" + b"x" * 5000)
    out += f.feed(b"y" * 5000)
    out += f.feed(b"tail-of-garbage\r\n" + HDT.encode() + b"\r\n")
    assert [fr.sentence for fr in out] == [HDT.encode()]
    assert health.counters["rejected.too_long"] == 1  # one over-long line, reported once
    assert health.counters["lines"] == 2


def test_framer_counts_add_up_and_logs_once(health, caplog):
    f = Framer(health)
    lines = [HDT, "# header", "", "$HEHDT,274.07,T*00", "$HEHDT,274.07,T*00", "junk", HDT]
    out = f.feed(("\r\n".join(lines) + "\r\n").encode())
    assert len(out) == 2
    c = health.counters
    assert c["lines"] == 5 and c["comments"] == 1
    assert c["rejected.checksum"] == 2 and c["rejected.no_start"] == 1
    # one log line per kind of problem, not per line
    assert c["errors"] == 2
