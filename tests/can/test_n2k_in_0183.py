"""NMEA 2000 in NMEA 0183 framing: SeaSmart `$PCDIN` and Shipmodul `$MXPGN`, alone or
mixed into an NMEA 0183 log, replayed through the CAN decoder.

Expected values are worked out by hand from the sentences (the examples of the
`nmea2000` package's docs):
- `$PCDIN,01F119,00000000,0F,2AAF00D1067414FF`: PGN 0x1F119 = 127257 (attitude) from
  address 0x0F; bus bytes 2A | AF 00 | D1 06 | 74 14: yaw 175e-4, pitch 0x06D1 = 1745e-4
  rad (10.0°), roll 0x1474 = 5236e-4 rad (30.0°).
- `$MXPGN,01F801,2801,C1308AC40C5DE343`: PGN 0x1F801 = 129025 (position, rapid);
  attribute 0x2801: received, priority 2, 8 bytes, address 1; bytes written most
  significant first, so on the bus 43 E3 5D 0C | C4 8A 30 C1: latitude 0x0C5DE343 =
  207479619e-7 = 20.7479619°, longitude 0xC1308AC4 as int32 = −1053783356e-7°.
"""

from __future__ import annotations

import contextlib
import io
from functools import reduce

import pytest

from edged.cli import main as cli
from edged.plugin import ReplayOptions
from edged_can.plugin import CanInput
from edged_nmea0183 import logfile as nmea_replay


def _s(body: str) -> str:
    return f"${body}*{reduce(lambda a, ch: a ^ ord(ch), body, 0):02X}"


RMC = _s("GPRMC,120000.00,A,5400.000,N,00700.000,E,10.0,45.0,011224,,,A")
RMC1 = _s("GPRMC,120001.00,A,5400.000,N,00700.000,E,10.0,45.0,011224,,,A")
PCDIN = _s("PCDIN,01F119,00000000,0F,2AAF00D1067414FF")
MXPGN = _s("MXPGN,01F801,2801,C1308AC40C5DE343")
T0 = 1733054400.0  # 2024-12-01T12:00:00Z, from the RMC


def _records(text: str, health):
    return list(nmea_replay.read_log(io.BytesIO(text.encode()), "mix", health, ReplayOptions()))


def _decode(records, health):
    dec = CanInput.make_decoder("mix", None, health)
    out = []
    for r in records:
        if r.protocol == "can":
            out.extend(dec.decode(r))
    return out


def test_sentences_among_nmea_0183_decode_as_on_a_bus(make_health):
    log = "\n".join([RMC, PCDIN, MXPGN, RMC1]) + "\n"
    health = make_health("mix")
    recs = _records(log, health)
    assert [r.protocol for r in recs] == ["nmea0183", "can", "can", "nmea0183"]
    assert all(r.t == pytest.approx(T0) for r in recs[1:3])  # timed like the sentences around them
    ms = _decode(recs, health)
    att = next(m for m in ms if m.kind == "attitude")
    assert att.source == "mix.15"
    assert att.values["pitch"] == pytest.approx(0.1745) and att.values["roll"] == pytest.approx(0.5236)
    pos = next(m for m in ms if m.kind == "position")
    assert pos.source == "mix.1"
    assert pos.values["lat"] == pytest.approx(20.7479619) and pos.values["lon"] == pytest.approx(-105.3783356)
    assert health.counters["n2k_sentences.pcdin"] == 1 and health.counters["n2k_sentences.mxpgn"] == 1


def test_a_log_of_them_replays_from_the_command_line(tmp_path):
    p = tmp_path / "seasmart.log"
    p.write_text("\n".join([RMC, PCDIN, MXPGN] * 3) + "\n")
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        assert cli(["replay", str(p), "--no-zenoh", "--no-progress"]) == 0
    text = out.getvalue()
    assert "attitude" in text and "position" in text


BAD = [
    (_s("MXPGN,01F801,2701,C1308AC40C5DE343"), "rejected.bad_length"),  # says 7 bytes, has 8
    (_s("MXPGN,01F801,A801,C1308AC40C5DE343"), "gateway_tx"),  # the gateway's own frame
    (PCDIN[:-2] + "00", "rejected.checksum"),  # the NMEA 0183 framer's own check
    (_s("PCDIN,01F119,00000000,0F,"), "rejected.bad_length"),  # no payload
    (_s("PCDIN,01F119,00000000,0F,2AAF00D1067414F"), "rejected.bad_line"),  # half a byte
    (_s("PCDIN,3FFFFF,00000000,0F,2AAF00D1067414FF"), "rejected.bad_pgn"),
]


@pytest.mark.parametrize("line,counter", BAD)
def test_bad_sentences_are_counted_and_the_rest_go_on(make_health, line, counter):
    health = make_health("mix")
    recs = _records("\n".join([RMC, PCDIN, line, PCDIN]) + "\n", health)
    ms = _decode(recs, health)
    assert [m.kind for m in ms] == ["attitude", "attitude"]
    assert health.counters[counter] == 1
