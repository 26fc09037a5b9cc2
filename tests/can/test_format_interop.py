"""One PGN stream, written in every gateway format by the `nmea2000` package's encoders,
read by our readers: identical measurements (issue 12, "a round-trip test per format").

The stream is ~500 `nmea2000.NMEA2000Message`s made with the package's own API (fields
by value: degrees, radians, m/s, dates, lookups by name), 10 s of a yacht off Kiel
(2024-06-01 from 10:15:00.000 UTC): PGN 126992 System Time first (the undated formats
take their date from it), heading (a true compass and a magnetic one), rate of turn,
attitude, rapid position, COG/SOG, GNSS position (fast-packet, two receivers), water
speed, depth; five sources. Every message time is a whole millisecond.

The reference is the same stream as frames on a CAN bus (the package's python-can
encoder, each frame a record with its identifier, as `CanInput` reads a bus). Each
format's log (bytes in memory) is read by OUR reader module (`edged_can.candump.read`,
`edged_can.formats.<module>.read`, `$PCDIN` / `$MXPGN` through
`edged_nmea0183.logfile.read_log` as `edged replay` reads an NMEA 0183 file) and every
record decoded by `CanInput.make_decoder(...).decode`: the measurements (kind, source,
values, time and device time to the millisecond) must equal the bus's, every message
be counted under its `pgn.<n>`, and no `rejected.*` counter appear.

Times: candump carries microseconds, Actisense plain and Yacht Devices RAW
milliseconds (YDWG a time of day, dated by the 126992), iKonvert a millisecond timer
(placed by the 126992), `$PCDIN` / `$MXPGN` the millisecond `c:` of a TAG block. The
stream's times are whole milliseconds, so every format must give them exactly; the
comparison is at 1 ms.

Who writes what (checked against our readers and the real gateways' logs in
../shared/data/n2k; `nmea2000` 2026.10.3):
- candump: `Candump3Encoder` (`candump -l`: `(1717236900.000000) slcan0 0DF01003#…`).
  As written. `Candump1/2Encoder` (old candump, screen output) write no time: the same
  values at 0.0, every line counted `untimed` (its own test).
- Actisense plain, reassembled fast-packets (`len` > 8, canboat's PLAIN_FAST, Signal
  K's `.data`): `BasicStringEncoder`. It writes `timestamp.isoformat() + "Z"`, so an
  aware UTC time comes out `…00.000+00:00Z`, which is no ISO time (the real logs write
  `…00.000Z`): it is given the same time without its zone (adapted input). Lower-case
  hex, as canboat writes it.
- Actisense plain, one frame per line: the package writes no such variant. Single-
  frame PGNs are `BasicStringEncoder`'s lines (one frame, `len` ≤ 8: the same line);
  fast-packet PGNs are our lines, in its format, around the package's own frames
  (`PythonCanEncoder`: its fast-packet split, sequence counter and 0xFF padding).
- Actisense plain, both (PLAIN_MIX_FAST): the two above, the reassembled line after
  its last frame; the decoder keeps one copy and counts the other.
- Yacht Devices RAW: `CanFrameAsciiRawEncoder` (`10:15:00.060 R 0DF80503 00 2B …`):
  the real format as written (8 hex digit id, upper-case bytes, the last fast-packet
  frame padded with 0xFF as a sender pads it; no CR, which the reader does not need).
- iKonvert `!PDGY`: `PdgyEncoder`. It writes the timer as `0.000` on every line: a
  real iKonvert writes its seconds since start, milliseconds NOT zero-padded
  (`482.37` is 482.037 s, canboat's ikonvert.log). A constant timer puts every line at
  the first 126992's time, so the timer field is replaced by the one a real gateway
  started 1234.567 s earlier would write (adapted input), and the gateway's `$PDGY`
  status line (as in the real log: `$PDGY,000000,4,,5,482,1,0`) is put in once a
  second: counted `gateway_status`, no measurement.
- `$PCDIN`: `PcdinEncoder` (`$PCDIN,01F112,00000000,07,…*2F`, checksum upper case, the
  SeaSmart timer field `00000000`, which our framer does not use). A sentence has no
  time of its own: each line gets a TAG block `\\c:<UNIX ms>*hh\\` (adapted input), the
  time a logger adds.
- `$MXPGN`: `MxpgnEncoder` for single-frame PGNs (`$MXPGN,01F112,2807,FC01…*15`: the
  attribute and the reversed byte order are the MiniPlex's, and our reader's). For a
  fast-packet PGN it is wrong: it writes the whole reassembled payload in one sentence
  (43 bytes of 129029) with the length cut to 4 bits (`3B03`), where a MiniPlex, like
  the bus, sends frame by frame, 8 bytes at most (our reader rejects it `bad_line`,
  rightly). Fast-packet PGNs are therefore our builder's sentences, one per frame of
  the package's `PythonCanEncoder`. TAG blocks as for `$PCDIN`.

Time zones: the package's decoders stamp messages with naive local times
(`datetime.fromtimestamp`), `Candump3Encoder` reads a naive time as local and
`BasicStringEncoder` writes it as if UTC, so the two agree only on a UTC machine. Every
message here is given its time explicitly (aware UTC; naive UTC for BasicString): the
test does not depend on the machine's zone (it passes under TZ=America/New_York).

Both directions: real logs (Yacht Devices RAW merrimac-ydwg-2020, all 914 lines; the
candump -l can0-1 log, its first 2000) read by our readers, their frames decoded by
the package (`NMEA2000Decoder`, python-can messages) and written back by the package
as candump and Actisense plain (whole and frames), give our measurements of the
original (`test_real_log_re_encoded_by_the_package_reads_back_identically`).
"""

from __future__ import annotations

import dataclasses
import io
import math
from collections import Counter
from datetime import datetime, timedelta, timezone
from functools import reduce
from typing import Any, Callable, Iterable, Iterator

import can
import pytest
from nmea2000 import NMEA2000Decoder, NMEA2000Field, NMEA2000Message, create_encoder
from nmea2000.input_formats import N2KFormat

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import Measurement, RawRecord
from edged_can import candump
from edged_can.formats import actisense_plain, ikonvert, ydwg_raw
from edged_can.plugin import CanInput
from edged_nmea0183 import logfile

BUS = "n2k"
#: 2024-06-01T10:15:00.000Z in UNIX milliseconds (19875 days, 36900 s).
T0_MS = (19875 * 86400 + 36900) * 1000
DURATION_MS = 10_000
#: How long the iKonvert had been running at T0 (its timer counts from its start).
IKONVERT_UPTIME_MS = 1_234_567
LAT0, LON0 = 54.3312, 10.1534  # Kiel fjord
GNSS, GNSS2, COMPASS, COMPASS_MAG, LOG = 3, 4, 7, 8, 35
VARIATION = math.radians(3.1)  # east, as the magnetic compass reports it
DEVIATION = math.radians(-0.5)
REAL_YDWG = "canboat__samples__merrimac-ydwg-2020.raw"


# ---- the stream, made with the package's API -------------------------------------


def _utc(t_ms: int) -> datetime:
    return datetime(1970, 1, 1, tzinfo=timezone.utc) + timedelta(milliseconds=t_ms)


def _message(t_ms: int, pgn: int, pgn_id: str, src: int, prio: int, **fields: Any) -> NMEA2000Message:
    return NMEA2000Message(
        PGN=pgn, id=pgn_id, source=src, destination=255, priority=prio, timestamp=_utc(t_ms),
        fields=[NMEA2000Field(id=k, value=v) for k, v in fields.items()],
    )


def _heading(s: float) -> float:
    """The yacht's true heading at s seconds: 40° turning at 0.6°/s."""
    return math.radians(40.0 + 0.6 * s)


def _position(s: float) -> tuple[float, float]:
    """Dead reckoning at 3.2 m/s along the heading (a small-angle chart)."""
    h = _heading(s / 2)
    dist = 3.2 * s
    return (LAT0 + dist * math.cos(h) / 111_320.0,
            LON0 + dist * math.sin(h) / (111_320.0 * math.cos(math.radians(LAT0))))


def _gnss(t_ms: int, src: int, sid: int, s: float) -> NMEA2000Message:
    lat, lon = _position(s)
    when = _utc(t_ms)
    return _message(
        t_ms, 129029, "gnssPositionData", src, 3,
        sid=sid, date=when.date(), time=when.time().replace(tzinfo=None),
        latitude=lat + (0.0 if src == GNSS else 2e-6), longitude=lon, altitude=2.5 + 0.1 * src,
        gnssType="GPS+GLONASS", method="GNSS fix", integrity="No integrity checking",
        numberOfSvs=11 if src == GNSS else 8, hdop=0.8 if src == GNSS else 1.3, pdop=1.4,
        geoidalSeparation=39.5, referenceStations=0,
    )


def stream() -> list[NMEA2000Message]:
    """The messages in time order (ties in the order they are listed)."""
    events: list[tuple[int, int, NMEA2000Message]] = []

    def at(t_ms: int, msg: NMEA2000Message) -> None:
        events.append((t_ms, len(events), msg))

    for k in range(DURATION_MS // 1000):  # 1 Hz
        t = T0_MS + 1000 * k
        when = _utc(t)
        at(t, _message(t, 126992, "systemTime", GNSS, 3, sid=k % 250, source="GPS",
                       date=when.date(), time=when.time().replace(tzinfo=None)))
        at(t + 60, _gnss(t + 60, GNSS, k % 250, k + 0.06))
        at(t + 560, _gnss(t + 560, GNSS2, k % 250, k + 0.56))
        s = k + 0.3
        at(t + 300, _message(t + 300, 128259, "speed", LOG, 2, sid=k % 250,
                             speedWaterReferenced=round(3.05 + 0.05 * math.sin(s), 2),
                             speedWaterReferencedType="Paddle wheel"))
        at(t + 310, _message(t + 310, 128267, "waterDepth", LOG, 3, sid=k % 250,
                             depth=round(14.2 + 0.3 * math.sin(s / 3), 2), offset=0.5))
    for k in range(DURATION_MS // 100):  # 10 Hz
        t = T0_MS + 100 * k
        s = k / 10
        at(t + 5, _message(t + 5, 127250, "vesselHeading", COMPASS, 2, sid=k % 250,
                           heading=_heading(s), reference="True"))
        at(t + 6, _message(t + 6, 127251, "rateOfTurn", COMPASS, 2, sid=k % 250,
                           rate=math.radians(0.6 + 0.05 * math.sin(s))))
        lat, lon = _position(s)
        at(t + 20, _message(t + 20, 129025, "positionRapidUpdate", GNSS, 2, latitude=lat, longitude=lon))
        if k % 2 == 0:  # 5 Hz
            at(t + 7, _message(t + 7, 127257, "attitude", COMPASS, 3, sid=k % 250, yaw=_heading(s),
                               pitch=math.radians(1.5 + 0.5 * math.sin(s)),
                               roll=math.radians(4.0 * math.sin(2 * math.pi * s / 6))))
            at(t + 50, _message(t + 50, 127250, "vesselHeading", COMPASS_MAG, 2, sid=k % 250,
                                heading=_heading(s) - VARIATION - DEVIATION, deviation=DEVIATION,
                                variation=VARIATION, reference="Magnetic"))
        if k % 5 == 0:  # 2 Hz
            at(t + 40, _message(t + 40, 129026, "cogSogRapidUpdate", GNSS, 2, sid=k % 250, cogReference="True",
                                cog=_heading(s) + math.radians(2.0), sog=round(3.2 + 0.1 * math.sin(s), 2)))
            lat, lon = _position(s)
            at(t + 70, _message(t + 70, 129025, "positionRapidUpdate", GNSS2, 2,
                                latitude=lat + 2e-6, longitude=lon))
    events.sort(key=lambda e: (e[0], e[1]))
    return [m for _, _, m in events]


STREAM = stream()
COUNTS = Counter(m.PGN for m in STREAM)
FAST = {pgn for pgn in COUNTS if NMEA2000Decoder.is_fast_pgn(pgn)}


def _lines(encoded: str | list[str]) -> list[str]:
    return [encoded] if isinstance(encoded, str) else list(encoded)


def _frames(msgs: Iterable[NMEA2000Message]) -> Iterator[tuple[NMEA2000Message, can.Message]]:
    """The bus frames of each message, by the package's python-can encoder."""
    enc = create_encoder(N2KFormat.PYTHON_CAN)
    for m in msgs:
        for f in enc.encode(m):
            yield m, f


def _nmea(body: str) -> str:
    """`body*hh`: the NMEA 0183 checksum, XOR of the characters between `$` and `*`."""
    return f"{body}*{reduce(lambda a, ch: a ^ ord(ch), body, 0):02X}"


def _tag(t_ms: int) -> str:
    """An NMEA 4.10 TAG block with the line's time (UNIX ms), as a logger writes it."""
    return "\\" + _nmea(f"c:{t_ms}") + "\\"


def _ms(msg: NMEA2000Message) -> int:
    return round(msg.timestamp.timestamp() * 1000)


# ---- the writers: one log (bytes) per format -------------------------------------


def write_candump(msgs: Iterable[NMEA2000Message]) -> bytes:
    enc = create_encoder(N2KFormat.CANDUMP3)
    return "".join(line + "\n" for m in msgs for line in _lines(enc.encode(m))).encode()


def _naive(m: NMEA2000Message) -> NMEA2000Message:
    """The message at the same UTC time without its zone: what BasicStringEncoder
    writes correctly (`+ "Z"` after `isoformat()`)."""
    return dataclasses.replace(m, timestamp=m.timestamp.astimezone(timezone.utc).replace(tzinfo=None))


def write_plain_fast(msgs: Iterable[NMEA2000Message]) -> bytes:
    enc = create_encoder(N2KFormat.BASIC_STRING)
    return "".join(enc.encode(_naive(m)) + "\n" for m in msgs).encode()


def _plain_frame_line(m: NMEA2000Message, frame: can.Message) -> str:
    """One frame as canboat's plain line (our writer: the package has none)."""
    stamp = _utc(_ms(m)).replace(tzinfo=None).isoformat(timespec="milliseconds") + "Z"
    data = bytes(frame.data)
    return ",".join([stamp, str(m.priority), str(m.PGN), str(m.source), str(m.destination), str(len(data)),
                     *(f"{b:02x}" for b in data)])


def _write_plain(msgs: Iterable[NMEA2000Message], frames: bool, whole: bool) -> bytes:
    enc = create_encoder(N2KFormat.BASIC_STRING)
    fragment = create_encoder(N2KFormat.PYTHON_CAN)
    out = []
    for m in msgs:
        if not NMEA2000Decoder.is_fast_pgn(m.PGN):
            out.append(enc.encode(_naive(m)))
            continue
        if frames:
            out += [_plain_frame_line(m, f) for f in fragment.encode(m)]
        if whole:
            out.append(enc.encode(_naive(m)))
    return "".join(line + "\n" for line in out).encode()


def write_plain_frames(msgs: Iterable[NMEA2000Message]) -> bytes:
    return _write_plain(msgs, frames=True, whole=False)


def write_plain_mix(msgs: Iterable[NMEA2000Message]) -> bytes:
    return _write_plain(msgs, frames=True, whole=True)


def write_ydwg(msgs: Iterable[NMEA2000Message]) -> bytes:
    enc = create_encoder(N2KFormat.CAN_FRAME_ASCII_RAW)
    return "".join(line + "\n" for m in msgs for line in _lines(enc.encode(m))).encode()


def _ikonvert_timer(t_ms: int) -> str:
    """The timer as a real iKonvert writes it: seconds since start, then milliseconds
    without zero padding (482.037 s is `482.37`)."""
    up = t_ms - T0_MS + IKONVERT_UPTIME_MS
    return f"{up // 1000}.{up % 1000}"


def write_ikonvert(msgs: Iterable[NMEA2000Message]) -> bytes:
    enc = create_encoder(N2KFormat.PDGY)
    out = []
    second = None
    for m in msgs:
        t = _ms(m)
        up_s = (t - T0_MS + IKONVERT_UPTIME_MS) // 1000
        if up_s != second:
            second = up_s
            out.append(f"$PDGY,000000,4,,5,{up_s},1,0")  # the gateway's status, as in the real log
        head, sep, b64 = enc.encode(m).rpartition(",")
        fields = head.split(",")
        assert fields[-1] == "0.000", fields  # the encoder's constant timer, replaced
        out.append(",".join(fields[:-1] + [_ikonvert_timer(t)]) + sep + b64)
    return "".join(line + "\n" for line in out).encode()


def write_pcdin(msgs: Iterable[NMEA2000Message]) -> bytes:
    enc = create_encoder(N2KFormat.PCDIN)
    return "".join(_tag(_ms(m)) + enc.encode(m) + "\n" for m in msgs).encode()


def _mxpgn_frame(m: NMEA2000Message, frame: can.Message) -> str:
    """One received frame as a MiniPlex writes it (our builder): attribute = priority
    << 12 | length << 8 | source, data most significant byte first."""
    data = bytes(frame.data)
    attr = (m.priority & 7) << 12 | len(data) << 8 | m.source
    return "$" + _nmea(f"MXPGN,{m.PGN:06X},{attr:04X},{data[::-1].hex().upper()}")


def write_mxpgn(msgs: Iterable[NMEA2000Message]) -> bytes:
    enc = create_encoder(N2KFormat.MXPGN)
    fragment = create_encoder(N2KFormat.PYTHON_CAN)
    out = []
    for m in msgs:
        if NMEA2000Decoder.is_fast_pgn(m.PGN):
            out += [_tag(_ms(m)) + _mxpgn_frame(m, f) for f in fragment.encode(m)]
        else:
            out.append(_tag(_ms(m)) + enc.encode(m))
    return "".join(line + "\n" for line in out).encode()


# ---- our readers, as `edged replay` calls them -----------------------------------


def _health() -> ComponentHealth:
    return ComponentHealth(BUS, "input", "can", ManualClock(0.0))


def read_candump(data: bytes, health: ComponentHealth) -> Iterator[RawRecord]:
    return candump.read(io.BytesIO(data), BUS, health, bus_from_line=False)


def read_plain(data: bytes, health: ComponentHealth) -> Iterator[RawRecord]:
    return actisense_plain.read(io.BytesIO(data), BUS, health, ReplayOptions())


def read_ydwg(data: bytes, health: ComponentHealth) -> Iterator[RawRecord]:
    return ydwg_raw.read(io.BytesIO(data), BUS, health, ReplayOptions())


def read_ikonvert(data: bytes, health: ComponentHealth) -> Iterator[RawRecord]:
    return ikonvert.read(io.BytesIO(data), BUS, health, ReplayOptions())


def read_0183(data: bytes, health: ComponentHealth) -> Iterator[RawRecord]:
    return logfile.read_log(io.BytesIO(data), BUS, health, ReplayOptions())


def bus_records(msgs: Iterable[NMEA2000Message]) -> list[RawRecord]:
    """The stream as a CAN bus gives it to the decoder: a frame, its id, its time."""
    return [RawRecord("can", BUS, f.timestamp, bytes(f.data), {"id": f.arbitration_id, "ext": True})
            for _, f in _frames(msgs)]


Row = tuple[str, str, int, tuple[tuple[str, Any], ...], int | None]


def _row(m: Measurement) -> Row:
    return (m.kind, m.source, round(m.t * 1000), tuple(sorted(m.values.items())),
            None if m.t_src is None else round(m.t_src * 1000))


def measure(records: Iterable[RawRecord], health: ComponentHealth) -> list[Row]:
    decoder = CanInput.make_decoder(BUS, None, health)
    out: list[Row] = []
    for r in records:
        assert r.protocol == "can", r
        out += [_row(m) for m in decoder.decode(r)]
    return out


def _rejected(health: ComponentHealth) -> dict[str, int]:
    return {k: v for k, v in health.counters.items() if k.startswith("rejected.")}


@pytest.fixture(scope="module")
def reference() -> tuple[list[Row], dict[str, int]]:
    health = _health()
    rows = measure(bus_records(STREAM), health)
    return rows, dict(health.counters)


# ---- the tests --------------------------------------------------------------------


def test_the_stream_on_a_bus_decodes_to_what_was_put_in(reference):
    """The reference itself: every message counted, the values those the stream was
    made of (to the PGNs' resolutions), so an empty or wrong reference fails here."""
    rows, counters = reference
    assert 400 <= len(STREAM) <= 700 and STREAM[0].PGN == 126992
    assert FAST == {129029}
    for pgn, n in COUNTS.items():
        assert counters.get(f"pgn.{pgn}") == n, pgn
    assert not {k: v for k, v in counters.items() if k.startswith("rejected.")}
    assert counters.get("fastpacket.lost", 0) == 0
    by_kind = Counter(r[0] for r in rows)
    # 126992 gives no measurement; both 127250s are headings (the magnetic one with
    # its own variation), both 129025 and 129029 positions.
    assert by_kind == {
        "heading": COUNTS[127250], "yaw_rate": COUNTS[127251], "attitude": COUNTS[127257],
        "position": COUNTS[129025] + COUNTS[129029], "velocity_ground": COUNTS[129026],
        "water_speed": COUNTS[128259], "depth": COUNTS[128267],
    }
    assert {r[1] for r in rows} == {f"{BUS}.{a}" for a in (GNSS, GNSS2, COMPASS, COMPASS_MAG, LOG)}
    first = {}
    for r in rows:
        first.setdefault((r[0], r[1]), r)
    hdg = dict(first[("heading", f"{BUS}.{COMPASS}")][3])
    assert hdg["heading"] == pytest.approx(math.radians(40.0), abs=1e-4)
    assert first[("heading", f"{BUS}.{COMPASS}")][2] == T0_MS + 5
    mag = dict(first[("heading", f"{BUS}.{COMPASS_MAG}")][3])
    assert mag["heading"] == pytest.approx(math.radians(40.0), abs=2e-4)  # magnetic + deviation + variation
    assert dict(first[("yaw_rate", f"{BUS}.{COMPASS}")][3])["r"] == pytest.approx(math.radians(0.6), abs=1e-6)
    pos = first[("position", f"{BUS}.{GNSS}")]  # 129025 at T0 + 20 ms
    assert pos[2] == T0_MS + 20
    assert dict(pos[3])["lat"] == pytest.approx(LAT0, abs=1e-7)
    gnss = next(r for r in rows if r[0] == "position" and r[4] is not None)  # 129029 at T0 + 60 ms
    assert gnss[2] == T0_MS + 60 and gnss[4] == T0_MS + 60  # its own time, to the ms
    assert dict(gnss[3])["sats"] == 11 and dict(gnss[3])["hdop"] == pytest.approx(0.8)
    vel = dict(first[("velocity_ground", f"{BUS}.{GNSS}")][3])
    assert vel["sog"] == pytest.approx(3.2) and vel["cog"] == pytest.approx(math.radians(42.0), abs=1e-4)
    assert dict(first[("water_speed", f"{BUS}.{LOG}")][3])["stw_long"] == pytest.approx(3.06)
    depth = dict(first[("depth", f"{BUS}.{LOG}")][3])
    assert depth["depth"] == pytest.approx(14.23) and depth["offset"] == pytest.approx(0.5)
    assert dict(first[("attitude", f"{BUS}.{COMPASS}")][3])["pitch"] == pytest.approx(math.radians(1.5), abs=1e-4)


Writer = Callable[[Iterable[NMEA2000Message]], bytes]
Reader = Callable[[bytes, ComponentHealth], Iterator[RawRecord]]

#: name -> (writer, reader, a line the log must contain (it is that format), counters
#: the format adds beside the bus's).
FORMATS: dict[str, tuple[Writer, Reader, str, dict[str, int]]] = {
    "candump": (write_candump, read_candump, f"({T0_MS // 1000}.000000) slcan0 0DF01003#", {}),
    "actisense_plain_fast": (write_plain_fast, read_plain, "2024-06-01T10:15:00.060Z,3,129029,3,255,43,",
                             {"messages": COUNTS[129029]}),
    "actisense_plain_frames": (write_plain_frames, read_plain, "2024-06-01T10:15:00.060Z,3,129029,3,255,8,",
                               {}),
    "actisense_plain_mix": (write_plain_mix, read_plain, "2024-06-01T10:15:00.060Z,3,129029,3,255,43,",
                            {"messages": COUNTS[129029], "duplicates.fast_messages": 2,
                             "duplicates.fast_frames": 7 * (COUNTS[129029] - 2)}),
    "ydwg_raw": (write_ydwg, read_ydwg, "10:15:00.060 R 0DF80503 ", {}),
    "ikonvert": (write_ikonvert, read_ikonvert, "!PDGY,126992,3,3,255,1234.567,",
                 {"messages": len(STREAM), "gateway_status": 1 + DURATION_MS // 1000}),
    "pcdin": (write_pcdin, read_0183, f"{_tag(T0_MS)}$PCDIN,01F010,00000000,03,",
              {"messages": len(STREAM), "n2k_sentences.pcdin": len(STREAM)}),
    "mxpgn": (write_mxpgn, read_0183, f"{_tag(T0_MS + 5)}$MXPGN,01F112,2807,",
              {"n2k_sentences.mxpgn": len(STREAM) + 6 * COUNTS[129029]}),
}


@pytest.mark.parametrize("name", list(FORMATS))
def test_every_format_gives_the_buss_measurements(name, reference):
    writer, reader, sample, extra = FORMATS[name]
    log = writer(STREAM)
    assert sample.encode() in log, log[:300]
    health = _health()
    rows = measure(reader(log, health), health)
    ref_rows, ref_counters = reference
    assert len(rows) == len(ref_rows)
    mismatch = [(a, b) for a, b in zip(rows, ref_rows) if a != b]
    assert not mismatch, mismatch[:3]
    c = health.counters
    assert not _rejected(health), _rejected(health)
    for pgn, n in COUNTS.items():  # every message of the stream accounted for
        assert c.get(f"pgn.{pgn}") == n, (pgn, c.get(f"pgn.{pgn}"))
    for k, n in extra.items():
        assert c.get(k) == n, (k, c.get(k))
    frames = sum(1 for _ in _frames(STREAM))
    if name in ("candump", "actisense_plain_frames", "ydwg_raw", "mxpgn"):
        assert c.get("frames") == frames  # frame-by-frame formats: every bus frame
    assert c.get("fastpacket.lost", 0) == 0


@pytest.mark.parametrize("fmt", [N2KFormat.CANDUMP1, N2KFormat.CANDUMP2])
def test_candump_layouts_without_time_give_the_values_untimed(fmt, reference):
    """`Candump1Encoder` (`<0x09F11207> [8] 03 39 …`, old candump) and `Candump2Encoder`
    (`can0  09F11207   [8]  03 39 …`, screen output without -t) write no time: our
    reader gives the same measurements at 0.0 and counts every line `untimed` (visible,
    not hidden); the device times of 129029 are still the device's."""
    enc = create_encoder(fmt)
    log = "".join(line + "\n" for m in STREAM for line in _lines(enc.encode(m))).encode()
    health = _health()
    rows = measure(read_candump(log, health), health)
    ref_rows, _ = reference
    assert rows == [(k, src, 0, v, ts) for k, src, _, v, ts in ref_rows]
    assert health.counters["untimed"] == sum(1 for _ in _frames(STREAM))
    assert not _rejected(health)


def test_the_package_mxpgn_encoder_writes_fast_packets_whole_which_no_miniplex_does():
    """Why fast-packet PGNs are our builder's $MXPGN: the package puts a 129029's 43
    bytes in one sentence, its length field cut to 4 bits; our framer rejects it."""
    from edged_can.formats import Bad, mxpgn

    gnss = next(m for m in STREAM if m.PGN == 129029)
    sentence = create_encoder(N2KFormat.MXPGN).encode(gnss)
    assert sentence.startswith("$MXPGN,01F805,3B03,") and len(sentence.split(",")[3].split("*")[0]) == 86
    with pytest.raises(Bad) as bad:
        mxpgn.frame(sentence.encode())
    assert bad.value.reason == "bad_line"


def test_the_package_basic_string_of_an_aware_time_is_no_iso_time():
    """Why the Actisense plain writer is given naive UTC times: the encoder appends
    "Z" to `isoformat()`, which already ends in +00:00 for an aware time."""
    line = create_encoder(N2KFormat.BASIC_STRING).encode(STREAM[0])
    assert line.startswith("2024-06-01T10:15:00.000+00:00Z,")
    health = _health()
    assert list(read_plain(line.encode() + b"\n", health)) == []
    assert health.counters.get("rejected.bad_line") == 1
    assert create_encoder(N2KFormat.BASIC_STRING).encode(_naive(STREAM[0])).startswith("2024-06-01T10:15:00.000Z,3,126992,")


# ---- the other direction: real logs' frames through the package and back ------

REAL_CANDUMP = "canboat__samples__can0-1.pcap__DERIVED_candump-l.log"
#: real log -> our reader of it (its first 2000 lines are used)
REAL = {REAL_YDWG: read_ydwg, REAL_CANDUMP: read_candump}


def _real_records(path, reader: Reader) -> tuple[list[RawRecord], ComponentHealth]:
    health = _health()
    with path.open("rb") as f:
        head = b"".join(line for _, line in zip(range(2000), f))
    return list(reader(head, health)), health


def _record_frames(r: RawRecord) -> list[tuple[int, bytes]]:
    """(identifier, data) of the bus frames a record holds."""
    fmt = r.meta.get("format")
    if fmt is None:
        return [(r.meta["id"], bytes(r.data))]
    return [(f.can_id, f.data) for f in ydwg_raw.frame(r.data)] if fmt == "ydwg_raw" else []


def _package_messages(records: list[RawRecord]) -> list[NMEA2000Message]:
    """Our records' frames decoded by the package (python-can messages, fast-packets
    reassembled by its reassembler), each given its record's time in UTC, rounded to
    the millisecond (what the Actisense plain target carries; `BasicStringEncoder`
    truncates to it)."""
    dec = NMEA2000Decoder(N2KFormat.PYTHON_CAN)
    out = []
    for r in records:
        for can_id, data in _record_frames(r):
            msg = dec.decode(can.Message(timestamp=r.t, arbitration_id=can_id, is_extended_id=True, data=data))
            if msg is not None:
                out.append(dataclasses.replace(msg, timestamp=_utc(round(r.t * 1000))))
    return out


@pytest.mark.parametrize("target", ["candump", "actisense_plain_fast", "actisense_plain_frames"])
@pytest.mark.parametrize("real", list(REAL))
def test_real_log_re_encoded_by_the_package_reads_back_identically(n2k_data, real, target):
    """A real log (Yacht Devices RAW, 914 lines; candump -l, its first 2000), read by
    our reader; its frames decoded by the package and written by the package as candump
    or Actisense plain; read back by our reader: the same measurements, in the same
    order, times to the ms, and the same counts of every measured PGN and of what was
    rejected or unavailable in the real data (the package drops the frames of PGNs it
    cannot decode, none of them ours)."""
    records, h0 = _real_records(n2k_data / real, REAL[real])
    assert len(records) == (914 if real == REAL_YDWG else 2000)
    original = measure(records, h0)
    kinds = Counter(r[0] for r in original)
    assert len(original) >= 100 and {"heading", "yaw_rate", "position"} <= set(kinds), kinds
    msgs = _package_messages(records)
    writer, reader, _, _ = FORMATS[target]
    health = _health()
    back = measure(reader(writer(msgs), health), health)
    assert len(back) == len(original)
    mismatch = [(a, b) for a, b in zip(back, original) if a != b]
    assert not mismatch, mismatch[:3]
    for k, n in h0.counters.items():
        if k.startswith(("pgn.", "measurements.", "rejected.", "unavailable.")):
            assert health.counters.get(k) == n, (k, health.counters.get(k), n)
    assert not {k for k in health.counters if k.startswith("rejected.")} - set(h0.counters)
