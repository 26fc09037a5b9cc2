"""Raw records of a recording whose time cannot be true (issue 10): `"t": Infinity`,
NaN, negative or centuries ahead are `rejected.bad_time`; the others replay and are
recorded again."""

from __future__ import annotations

import io
import json
from functools import reduce
from operator import xor

import pytest
from mcap.writer import CompressionType, Writer

from edged.cli import main
from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged_mcap.logs import MCAP
from edged_mcap.rawreader import read_raw

T0 = 1732350000.0


def _hdt(h: float) -> str:
    body = f"HEHDT,{h:.1f},T"
    return "$%s*%02X" % (body, reduce(xor, body.encode(), 0))


def _handmade(payloads: list[bytes]) -> bytes:
    buf = io.BytesIO()
    w = Writer(buf, compression=CompressionType.NONE)
    w.start()
    sid = w.register_schema("edged.raw", "jsonschema", b"{}")
    cid = w.register_channel("/raw/nmea0183/gyro", "json", sid)
    for i, data in enumerate(payloads):
        w.add_message(cid, i + 1, data, i + 1)
    w.finish()
    return buf.getvalue()


def _msg(t: str | float, h: float) -> bytes:
    t_text = t if isinstance(t, str) else repr(t)
    return ('{"t": %s, "line": %s, "meta": null}' % (t_text, json.dumps(_hdt(h)))).encode()


def _with(bad: str) -> bytes:
    return _handmade([_msg(T0, 1.0), _msg(T0 + 1, 2.0), _msg(bad, 99.0), _msg(T0 + 2, 3.0), _msg(T0 + 3, 4.0)])


def _health() -> ComponentHealth:
    return ComponentHealth("f", "input", "mcap", ManualClock(0.0))


@pytest.mark.parametrize("bad", ["Infinity", "-Infinity", "NaN", "-1.0", "1e300", "20000000000.0", "1" + "0" * 400])
def test_a_raw_message_with_a_time_that_cannot_be_true_costs_itself_only(bad):
    h = _health()
    recs = list(MCAP.open(io.BytesIO(_with(bad)), "f", h, ReplayOptions()))
    assert [r.t for r in recs] == [T0, T0 + 1, T0 + 2, T0 + 3]
    assert h.counters["rejected.bad_time"] == 1


def test_untimed_records_at_zero_and_files_days_apart_are_kept():
    data = _handmade([_msg(0.0, 1.0), _msg(T0, 2.0), _msg(T0 + 7 * 86400, 3.0)])
    h = _health()
    assert [r.t for r in read_raw(io.BytesIO(data), h, "x")] == [0.0, T0, T0 + 7 * 86400]
    assert "rejected.bad_time" not in h.counters


def test_replay_record_of_a_recording_with_an_infinite_time(tmp_path, capsys):
    src = tmp_path / "in.mcap"
    src.write_bytes(_with("Infinity"))
    out = tmp_path / "out.mcap"
    rc = main(["replay", str(src), "--no-zenoh", "--no-progress", "--record", str(out)])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "replayed 4 records, 3.0 s of data" in text
    with out.open("rb") as f:
        assert [r.t for r in read_raw(f, _health(), out)] == [T0, T0 + 1, T0 + 2, T0 + 3]
