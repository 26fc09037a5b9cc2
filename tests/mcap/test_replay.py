"""Recordings read back for replay: raw records come out exactly as they went in."""

from __future__ import annotations

import io
import json
from pathlib import Path

from hypothesis import HealthCheck, given, settings, strategies as st
from mcap.writer import CompressionType, Writer

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import Measurement, RawRecord
from edged_mcap.logs import MCAP


def _health() -> ComponentHealth:
    return ComponentHealth("f", "input", "mcap", ManualClock(0.0))


def _replay(data: bytes, health: ComponentHealth | None = None) -> list[RawRecord]:
    return list(MCAP.open(io.BytesIO(data), "f", health or _health(), ReplayOptions()))


def _write(make_rig, path: Path, recs, **cfg) -> None:
    rig = make_rig(path=str(path), **cfg)
    rig.open()
    rig.rec.write(recs)
    rig.close()


_json_scalar = st.one_of(
    st.none(), st.booleans(), st.integers(-(2**63), 2**63), st.floats(allow_nan=False, allow_infinity=False), st.text(max_size=8)
)
_raw = st.builds(
    RawRecord,
    st.sampled_from(["nmea0183", "can", "seatalk"]),
    st.text(min_size=1, max_size=12),
    st.floats(min_value=0.0, max_value=4e9, allow_nan=False),
    st.binary(max_size=40),
    st.one_of(st.none(), st.dictionaries(st.text(max_size=6), _json_scalar, max_size=4)),
)


# make_rig is a stateless factory: sharing it between examples is safe.
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(_raw, min_size=1, max_size=30))
def test_raw_records_round_trip_exactly(tmp_path_factory, make_rig, recs):
    path = tmp_path_factory.mktemp("rt") / "rt.mcap"
    _write(make_rig, path, recs)
    assert _replay(path.read_bytes()) == recs


def test_only_raw_channels_are_replayed_in_file_order(make_rig, tmp_path, records):
    path = tmp_path / "r.mcap"
    _write(make_rig, path, records)
    back = _replay(path.read_bytes())
    assert back == [r for r in records if isinstance(r, RawRecord)]
    assert any(isinstance(r, Measurement) for r in records)


def test_sniff_recognises_mcap_only(make_rig, tmp_path):
    path = tmp_path / "s.mcap"
    _write(make_rig, path, [])
    assert MCAP.sniff(path.read_bytes()[:64])
    assert not MCAP.sniff(b"$GPGGA,123519,4807.038,N*47\r\n")
    assert not MCAP.sniff(b"(1732350000.123456) can0 09F11201#00")


def _handmade(messages: list[tuple[str, bytes]]) -> bytes:
    buf = io.BytesIO()
    w = Writer(buf, compression=CompressionType.NONE)
    w.start()
    sid = w.register_schema("x", "jsonschema", b"{}")
    ids: dict[str, int] = {}
    for i, (topic, data) in enumerate(messages):
        cid = ids.setdefault(topic, w.register_channel(topic, "json", sid))
        w.add_message(cid, i + 1, data, i + 1)
    w.finish()
    return buf.getvalue()


def test_undecodable_raw_messages_are_counted_and_skipped():
    good = json.dumps({"t": 3.0, "line": "$OK*00", "meta": None}).encode()
    data = _handmade(
        [
            ("/raw/nmea0183/a", b"{not json"),
            ("/raw/nmea0183/a", b"\xff\xfe"),
            ("/raw/nmea0183/a", json.dumps({"t": 1.0}).encode()),  # no line, no data
            ("/raw/can/c", json.dumps({"t": 1.0, "data": "zz"}).encode()),  # bad hex
            ("/raw/can/c", json.dumps({"t": "soon", "data": "00"}).encode()),  # bad time
            ("/raw/nmea0183/a", json.dumps([1, 2]).encode()),  # not an object
            ("/raw/nothing", json.dumps({"t": 1.0, "data": "00"}).encode()),  # topic without source
            ("/raw/nmea0183/a", good),
        ]
    )
    h = _health()
    assert _replay(data, h) == [RawRecord("nmea0183", "a", 3.0, b"$OK*00", None)]
    assert h.counters["rejected.bad_json"] == 2
    assert h.counters["rejected.bad_raw"] == 5
    assert "truncated" not in h.counters


def test_a_file_that_is_not_mcap_is_counted_not_raised():
    h = _health()
    assert _replay(b"$GPGGA,not an mcap file\r\n" * 10, h) == []
    assert h.counters["rejected.not_mcap"] == 1
    h2 = _health()
    assert _replay(b"", h2) == []
    assert h2.counters["rejected.not_mcap"] == 1


def test_unfinished_file_replays_its_complete_chunks(make_rig, tmp_path, sample):
    recs = [r for r in sample(seconds=10) if isinstance(r, RawRecord)]
    rig = make_rig(path=str(tmp_path / "u.mcap"), chunk_kib=2, fsync=False)
    rig.open()
    half = len(recs) // 2
    rig.rec.write(recs[:half])
    rig.rec.flush()  # everything so far is in complete chunks
    rig.rec.write(recs[half:])  # part of this is in the open chunk, never finished
    data = (tmp_path / "u.mcap").read_bytes()
    cut = data[: len(data) - 100]  # and the last written chunk is cut short
    h = _health()
    back = _replay(cut, h)
    assert back == recs[: len(back)]
    assert half <= len(back) < len(recs)
    assert h.counters["truncated"] == 1
    assert "unfinished" in h.last_error


def test_a_damaged_chunk_is_skipped_and_the_rest_read(make_rig, tmp_path, sample):
    recs = [r for r in sample(seconds=6) if isinstance(r, RawRecord)]
    path = tmp_path / "d.mcap"
    rig = make_rig(path=str(path), chunk_kib=2, compression="none")
    rig.open()
    third = len(recs) // 3
    for part in (recs[:third], recs[third : 2 * third], recs[2 * third :]):
        rig.rec.write(part)
        rig.rec.flush()
    rig.close()
    data = bytearray(path.read_bytes())
    at = data.index(b"$GPGGA", len(data) // 3)  # inside a chunk in the middle
    data[at] ^= 0xFF
    h = _health()
    back = _replay(bytes(data), h)
    assert h.counters["rejected.bad_chunk"] == 1
    assert back[0] == recs[0] and back[-1] == recs[-1]
    assert len(back) < len(recs)
