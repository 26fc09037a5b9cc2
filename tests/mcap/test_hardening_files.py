"""Damaged and foreign MCAP files (issue 10): read up to the damage, counted, bounded.

A valid header followed by random bytes, a chunk whose length field is 2^63 or points
past the end of the file, a chunk whose inner fields lie, a file that holds only the
magic: `replay`, `inspect`, `export`, `plot` and `recover` must say what is damaged,
never print a traceback, never allocate what a length field claims, and still give
everything before the damage.
"""

from __future__ import annotations

import os
import io
import math
import random
import struct
import tracemalloc
from pathlib import Path
from typing import Any, Callable

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st
from mcap.exceptions import McapError
from mcap.writer import CompressionType, Writer

from edged.cli import main as cli
from edged.clock import ManualClock
from edged.flatten import flatten
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import RawRecord
from edged_analysis.plotdata import collect
from edged_mcap import reading
from edged_mcap.reading import MAGIC, NoRecords, ReadReport, iter_messages, iter_records
from edged_mcap.logs import MCAP
from edged_mcap.recovery import recover
from edged_mcap.stats import file_stats
from mcap_rig import foreign_mcap

_CHUNK = 0x06
_HEADER = 0x01
_MIB = 1 << 20


# -- building damaged files --------------------------------------------------------------
def _record(make_rig, path: Path, records: list[Any], *, compression: str = "zstd") -> bytes:
    rig = make_rig(path=str(path), chunk_kib=2, compression=compression)
    rig.open()
    rig.rec.write(records)
    rig.close()
    return path.read_bytes()


def _layout(data: bytes) -> list[tuple[int, int, int]]:
    """(offset, opcode, length) of every top-level record of a valid file."""
    out = []
    pos = len(MAGIC)
    while pos + 9 <= len(data) - len(MAGIC):
        op, length = struct.unpack_from("<BQ", data, pos)
        out.append((pos, op, length))
        pos += 9 + length
    return out


def _chunks(data: bytes) -> list[int]:
    return [pos for pos, op, _ in _layout(data) if op == _CHUNK]


def _field(data: bytes, chunk: int, name: str) -> int:
    """Offset of a field of the chunk record at `chunk`."""
    body = chunk + 9
    if name == "uncompressed_size":
        return body + 16
    if name == "compression_length":
        return body + 28
    (clen,) = struct.unpack_from("<I", data, body + 28)
    assert name == "records_length"
    return body + 32 + clen


def _put(data: bytes, at: int, fmt: str, value: int) -> bytes:
    b = bytearray(data)
    struct.pack_into(fmt, b, at, value)
    return bytes(b)


def _header_end(data: bytes) -> int:
    (pos, op, length) = _layout(data)[0]
    assert op == _HEADER
    return pos + 9 + length


def _damage(data: bytes, kind: str) -> tuple[bytes, int]:
    """The damaged file and the offset of the damaged record (the middle chunk)."""
    at = _chunks(data)[len(_chunks(data)) // 2]
    if kind == "chunk_length_2^63":
        return _put(data, at + 1, "<Q", 1 << 63), at
    if kind == "chunk_length_past_the_end":  # within 1 GiB, far beyond the file
        return _put(data, at + 1, "<Q", 1 << 29), at
    if kind == "records_length_2^63":
        return _put(data, _field(data, at, "records_length"), "<Q", 1 << 63), at
    if kind == "compression_length_2^31":
        return _put(data, _field(data, at, "compression_length"), "<I", 1 << 31), at
    if kind == "uncompressed_size_2^63":
        return _put(data, _field(data, at, "uncompressed_size"), "<Q", 1 << 63), at
    if kind == "uncompressed_size_2^40":  # the zstd frame says otherwise: still a lie
        return _put(data, _field(data, at, "uncompressed_size"), "<Q", 1 << 40), at
    if kind == "random_after_header":
        rnd = random.Random(10)
        end = _header_end(data)
        # A known opcode and a length within the record limit but far beyond the file,
        # then noise: what a reader must not allocate for.
        tail = bytes([_CHUNK]) + struct.pack("<Q", 300 * _MIB) + rnd.randbytes(5000)
        return data[:end] + tail, end
    raise AssertionError(kind)


#: damage -> (what the report says, records after the damage are still read)
_DAMAGES = {
    "chunk_length_2^63": ("error", False),
    "chunk_length_past_the_end": ("truncated", False),
    "records_length_2^63": ("bad_chunk", True),
    "compression_length_2^31": ("bad_chunk", True),
    "uncompressed_size_2^63": ("bad_chunk", True),
    "uncompressed_size_2^40": ("bad_chunk", True),
    "random_after_header": ("truncated", False),
}


def _peak(fn: Callable[[], Any]) -> tuple[Any, int]:
    """fn()'s result and the peak of Python memory allocated while it ran (bytes)."""
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        out = fn()
        return out, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _messages(stream: io.BufferedIOBase, report: ReadReport) -> list[tuple[str, bytes]]:
    return [(ch.topic, m.data) for ch, _s, m in iter_messages(stream, report)]


def _buffered(data: bytes) -> io.BufferedReader:
    """The data behind a BufferedReader, which (like a file) allocates what read(n) asks."""
    return io.BufferedReader(io.BytesIO(data), 1 << 16)


@pytest.fixture
def good(make_rig, tmp_path, sample) -> bytes:
    return _record(make_rig, tmp_path / "good.mcap", sample(seconds=3))


# -- item 1: the reader ------------------------------------------------------------------
@pytest.mark.parametrize("kind", sorted(_DAMAGES))
def test_damage_is_counted_everything_before_it_read_and_memory_bounded(good, kind):
    bad, at = _damage(good, kind)
    before = _messages(_buffered(good[:at]), ReadReport())  # the file cut just before the damage
    everything = _messages(_buffered(good), ReadReport())
    report = ReadReport()
    got, peak = _peak(lambda: _messages(_buffered(bad), report))
    assert peak < 8 * _MIB, f"{peak / _MIB:.0f} MiB for a {len(bad) / 1024:.0f} KiB file"
    assert got[: len(before)] == before
    assert before or kind == "random_after_header"  # (only the header comes before that)
    what, goes_on = _DAMAGES[kind]
    if what == "error":
        assert report.error is not None and report.error.startswith("damaged: CHUNK record at byte")
        assert str(1 << 63) in report.error and report.damaged and not report.healthy
    elif what == "truncated":
        assert report.truncated and not report.finished and report.error is None
    else:
        assert report.bad_chunks == 1 and report.damaged and report.finished
        assert report.bad_chunk_errors[0]
    if goes_on:  # only the damaged chunk is lost
        assert got[-1] == everything[-1]
        assert len(before) < len(got) < len(everything)
    else:
        assert got == before


def test_a_record_length_within_the_limit_but_beyond_the_file_costs_what_the_file_holds(good):
    end = _header_end(good)
    bad = good[:end] + bytes([0x09]) + struct.pack("<Q", (1 << 30) - 1) + b"x" * 100  # an attachment
    report = ReadReport()
    _, peak = _peak(lambda: list(iter_records(_buffered(bad), report)))
    assert peak < 4 * _MIB
    assert report.truncated


def test_a_chunk_that_decompresses_beyond_the_limit_is_not_decompressed(make_rig, tmp_path, sample):
    data = _record(make_rig, tmp_path / "z.mcap", sample(seconds=1))
    cap = max(length for _pos, _op, length in _layout(data))  # every record fits
    sizes = [struct.unpack_from("<Q", data, _field(data, at, "uncompressed_size"))[0] for at in _chunks(data)]
    too_big = sum(1 for size in sizes if size > cap)
    assert too_big > 0
    report = ReadReport()
    records = list(iter_records(io.BytesIO(data), report, max_record=cap))
    assert report.bad_chunks == too_big and report.chunks == len(sizes) - too_big
    assert f"uncompressed (limit {cap})" in report.bad_chunk_errors[0]
    assert report.finished and report.error is None and records


def test_a_zip_bomb_chunk_is_refused_without_being_inflated(tmp_path):
    import zstandard

    bomb = zstandard.ZstdCompressor().compress(b"\0" * (64 * _MIB))  # a few KiB
    buf = io.BytesIO()
    w = Writer(buf, compression=CompressionType.NONE)
    w.start()
    w.finish()
    head = buf.getvalue()[: _header_end(buf.getvalue())]
    # A chunk that declares 10 bytes uncompressed but inflates to 64 MiB.
    body = struct.pack("<QQQI", 0, 0, 10, 0) + struct.pack("<I", 4) + b"zstd" + struct.pack("<Q", len(bomb)) + bomb
    data = head + bytes([_CHUNK]) + struct.pack("<Q", len(body)) + body + MAGIC
    report = ReadReport()
    _, peak = _peak(lambda: list(iter_records(_buffered(data), report)))
    assert report.bad_chunks == 1 and "more than its declared 10 bytes" in report.bad_chunk_errors[0]
    assert peak < 8 * _MIB


def test_a_damaged_record_outside_chunks_is_skipped_and_counted(make_rig, tmp_path, sample):
    data = _record(make_rig, tmp_path / "m.mcap", sample(seconds=3))
    meta = next(pos for pos, op, _ in _layout(data) if op == 0x0C)
    bad = _put(data, meta + 9, "<I", 1 << 31)  # the metadata record's name length
    report = ReadReport()
    msgs = _messages(io.BytesIO(bad), report)
    assert msgs == _messages(io.BytesIO(data), ReadReport())
    assert report.bad_records == 1 and report.damaged and not report.healthy
    assert report.bad_record_errors[0].startswith(f"METADATA record at byte {meta}")


# -- item 1: the commands ----------------------------------------------------------------
def _run(argv: list[str], capsys) -> tuple[int, str, str]:
    rc = cli(argv)
    out, err = capsys.readouterr()
    assert "Traceback" not in err and "Traceback" not in out
    return rc, out, err


@pytest.mark.parametrize("kind", ["records_length_2^63", "chunk_length_2^63", "chunk_length_past_the_end", "random_after_header"])
def test_commands_on_a_damaged_file_say_so_without_a_traceback(good, kind, tmp_path, capsys):
    bad, _ = _damage(good, kind)
    path = tmp_path / "bad.mcap"
    path.write_bytes(bad)
    what, _ = _DAMAGES[kind]
    has_data = kind != "random_after_header"

    rc, out, _ = _run(["inspect", str(path)], capsys)
    assert rc == 0
    health = next(ln for ln in out.splitlines() if ln.startswith("health"))
    assert {"bad_chunk": "1 damaged chunk(s) skipped", "error": "UNFINISHED (damaged: CHUNK record", "truncated": "UNFINISHED"}[what] in health

    rc, out, err = _run(["export", str(path), "--topic", "/raw/nmea0183/gnss1", "--format", "jsonl"], capsys)
    assert rc == (0 if has_data else 2)
    if has_data:
        assert len(out.splitlines()) > 0
    else:
        assert "no messages" in err

    rc, out, _ = _run(["recover", str(path)], capsys)
    assert rc == (0 if has_data else 1)
    if what == "bad_chunk":
        assert "was damaged" in out and "skipped 1 damaged chunk(s)" in out
    elif what == "error":
        assert "stopped reading at: damaged: CHUNK record" in out
    else:
        assert "was unfinished" in out

    rc, _, err = _run(["plot", str(path), "-o", str(tmp_path / "p.png")], capsys)
    assert rc == (0 if has_data else 1), err


@pytest.mark.parametrize("kind", ["records_length_2^63", "chunk_length_2^63"])
def test_replay_of_a_damaged_file_counts_the_damage_in_the_source_health(good, kind, tmp_path, capsys):
    bad, at = _damage(good, kind)
    path = tmp_path / "bad.mcap"
    path.write_bytes(bad)
    rc, out, err = _run(["replay", str(path), "--no-zenoh", "--no-progress"], capsys)
    assert rc == 0
    counters = {
        ln.split()[-2]: int(ln.split()[-1])
        for ln in out.splitlines()
        if ln.strip().startswith(("rejected", "truncated", "damaged", "bad"))
    }
    if kind == "records_length_2^63":
        assert counters["rejected.bad_chunk"] == 1
        assert "damaged chunk(s) skipped" in err
    else:  # a length that cannot be true is damage, not a file that just stops
        assert counters["damaged"] == 1 and "truncated" not in counters
        assert f"damaged: CHUNK record at byte {at}" in err
    n_raw = sum(1 for ch, _s, _m in iter_messages(io.BytesIO(bad), ReadReport()) if ch.topic.startswith("/raw/"))
    assert f"replayed {n_raw} records" in out and n_raw > 0


@pytest.mark.parametrize(
    "fn",
    [
        pytest.param(lambda p: file_stats(p), id="inspect"),
        pytest.param(lambda p: collect(p), id="plot"),
        pytest.param(lambda p: recover(p, p.with_name("r.mcap")), id="recover"),
        pytest.param(lambda p: _messages(open(p, "rb"), ReadReport()), id="export"),
        pytest.param(lambda p: list(MCAP.open(open(p, "rb"), "f", _health(), ReplayOptions())), id="replay"),
    ],
)
def test_what_each_command_reads_stays_small_on_a_lying_length(good, fn, tmp_path):
    bad, _ = _damage(good, "chunk_length_past_the_end")
    path = tmp_path / "bad.mcap"
    path.write_bytes(bad)
    _, peak = _peak(lambda: fn(path))
    assert peak < 16 * _MIB


# -- item 2: the magic and nothing else --------------------------------------------------
def test_a_file_with_only_the_magic_is_refused_like_an_empty_one():
    with pytest.raises(NoRecords, match="no records: the file holds only the MCAP magic") as e:
        list(iter_records(io.BytesIO(MAGIC), ReadReport()))
    assert e.value.reason == "holds only the MCAP magic"  # for "no records: <file> holds only ..."
    with pytest.raises(NoRecords, match="ends inside its first record"):
        list(iter_records(io.BytesIO(MAGIC + b"\x01\x05\x00"), ReadReport()))
    with pytest.raises(NoRecords, match="begins with a CHUNK record, not the MCAP header"):  # no header at all
        list(iter_records(io.BytesIO(MAGIC + bytes([_CHUNK]) + struct.pack("<Q", 0) + MAGIC), ReadReport()))
    with pytest.raises(NoRecords, match="is damaged: its header claims"):
        list(iter_records(io.BytesIO(MAGIC + bytes([_HEADER]) + struct.pack("<Q", 1 << 63)), ReadReport()))
    # NoRecords is an McapError: every command that refuses a non-MCAP file refuses these.
    assert issubclass(NoRecords, McapError)
    with pytest.raises(McapError) as e:
        list(iter_records(io.BytesIO(b""), ReadReport()))
    assert not isinstance(e.value, NoRecords)


@pytest.mark.parametrize("cmd", ["inspect", "export", "recover", "plot"])
def test_commands_refuse_a_file_holding_only_the_magic(cmd, tmp_path, capsys):
    path = tmp_path / "magic.mcap"
    path.write_bytes(MAGIC)
    extra = {"export": ["--topic", "/health"], "plot": ["-o", str(tmp_path / "p.png")]}.get(cmd, [])
    rc, _, err = _run([cmd, str(path), *extra], capsys)
    assert rc == 1
    assert f"{path}: no records: the file holds only the MCAP magic" in err
    assert not path.with_name("magic.recovered.mcap").exists()


def _health() -> ComponentHealth:
    return ComponentHealth("f", "input", "mcap", ManualClock(0.0))


def test_replay_reader_names_a_file_holding_only_the_magic():
    from edged.logformats import UnknownFormat

    with pytest.raises(UnknownFormat, match="no records: f holds only the MCAP magic"):
        list(MCAP.open(io.BytesIO(MAGIC), "f", _health(), ReplayOptions()))


def test_replay_of_a_file_holding_only_the_magic_exits_2_like_an_empty_one(tmp_path, capsys):
    path = tmp_path / "magic.mcap"
    path.write_bytes(MAGIC)
    assert cli(["replay", str(path), "--no-zenoh", "--no-progress"]) == 2
    assert "holds only the MCAP magic" in capsys.readouterr().err


# -- foreign payloads: what plot and export flatten --------------------------------------
def test_plot_data_skips_numbers_no_float_holds_and_json_nested_too_deep(tmp_path):
    huge = "1" + "0" * 400  # a JSON integer: valid, but beyond any float
    path = foreign_mcap(
        tmp_path / "f.mcap",
        [
            ("/est/stw", b'{"stw": %s, "sog": 2.0}' % huge.encode()),
            ("/est/stw", b'{"stw": 3.0}'),
            ("/meas/position/g", b'{"lat": %s, "lon": 1.0}' % huge.encode()),
            ("/meas/position/g", b'{"lat": 1e300, "lon": 1.0}'),
            ("/meas/position/g", b'{"lat": 60.0, "lon": 24.0}'),
            ("/meas/draft/d", b'{"mark": "fwd", "draft": %s}' % huge.encode()),
            ("/est/draft", b'{"marks": {"fore": {"mean": %s}}}' % huge.encode()),
            ("/est/manoeuvre", b"[" * 100_000 + b"]" * 100_000),
        ],
        step_ns=10**8,
    )
    data = collect(path)
    speed = data.panel("speed")
    assert speed["STW (estimate)"].y == [pytest.approx(3.0 * 3600 / 1852)]
    assert len(speed["SOG (estimate)"].y) == 1
    assert data.tracks == {"g": ([60.0], [24.0])}
    assert all(math.isfinite(y) for panel in data.series.values() for s in panel.values() for y in s.y)


def test_flatten_walks_any_depth_in_order():
    deep: dict[str, Any] = {"v": 1}
    for _ in range(5000):
        deep = {"a": deep}
    (key,) = flatten(deep)
    assert key == "a." * 5000 + "v"
    assert list(flatten({"a": {"b": 1, "c": {"d": [1, 2]}, "e": {}}, "f": 2, "g": {"h": 3}}).items()) == [
        ("a.b", 1),
        ("a.c.d", "[1,2]"),
        ("a.e", None),
        ("f", 2),
        ("g.h", 3),
    ]
    assert flatten({"x": 1}, "p.") == {"p.x": 1}


# -- item 3: fuzzing the reading path replay uses ----------------------------------------
_BASES: dict[str, bytes] = {}


@pytest.fixture
def bases(make_rig, tmp_path_factory, sample) -> dict[str, bytes]:
    if not _BASES:
        d = tmp_path_factory.mktemp("bases")
        for comp in ("zstd", "lz4", "none"):
            _BASES[comp] = _record(make_rig, d / f"{comp}.mcap", sample(seconds=1), compression=comp)
    return _BASES


_HUGE = st.sampled_from([1 << 63, (1 << 64) - 1, 1 << 40, 1 << 32, (1 << 30) + 1, 1 << 30, 1 << 29, 1 << 20, 0])


_BYTE_LEVEL = ["truncate", "flip", "splice", "overwrite"]
_STRUCTURAL = ["length", "chunk_field"]  # aimed at the fields of a valid file


def _mutate(draw: st.DrawFn, data: bytes, kinds: list[str]) -> bytes:
    kind = draw(st.sampled_from(kinds))
    n = len(data)
    if kind == "truncate":
        return data[: draw(st.integers(0, n))]
    if kind == "flip":
        b = bytearray(data)
        for at, mask in draw(st.lists(st.tuples(st.integers(0, n - 1), st.integers(1, 255)), min_size=1, max_size=8)):
            b[at] ^= mask
        return bytes(b)
    if kind == "length":  # a top-level record's length field
        pos, _op, _len = draw(st.sampled_from(_layout(data)))
        return _put(data, pos + 1, "<Q", draw(_HUGE))
    if kind == "chunk_field":
        at = draw(st.sampled_from(_chunks(data)))
        name = draw(st.sampled_from(["uncompressed_size", "compression_length", "records_length"]))
        fmt = "<I" if name == "compression_length" else "<Q"
        value = draw(_HUGE) & (0xFFFFFFFF if fmt == "<I" else (1 << 64) - 1)
        return _put(data, _field(data, at, name), fmt, value)
    at = draw(st.integers(0, n))
    junk = draw(st.binary(min_size=1, max_size=64))
    if kind == "splice":
        return data[:at] + junk + data[at:]
    return data[:at] + junk + data[at + len(junk) :]


@st.composite
def _damaged(draw: st.DrawFn, names: tuple[str, ...]) -> tuple[str, bytes]:
    """A valid recording damaged 1 to 3 times: first anywhere (its fields too), then bytes."""
    name = draw(st.sampled_from(names))
    data = _mutate(draw, _BASES[name], _BYTE_LEVEL + _STRUCTURAL)
    for _ in range(draw(st.integers(0, 2))):
        if data:
            data = _mutate(draw, data, _BYTE_LEVEL)
    return name, data


_CAP = 256 * 1024


@settings(derandomize=True, max_examples=int(os.environ.get("EDGED_FUZZ_EXAMPLES", "200")), deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(st.data())
def test_fuzz_the_replay_reading_path(bases, monkeypatch, data):
    monkeypatch.setattr(reading, "MAX_RECORD", _CAP)  # a small cap: a bound a test can see
    _name, blob = data.draw(_damaged(tuple(sorted(bases))))

    # The records the reader yields: only McapError is ever raised.
    report = ReadReport()
    refused: list[McapError] = []

    def read_all() -> list[Any]:
        try:
            return list(iter_records(_buffered(blob), report))
        except McapError as exc:
            refused.append(exc)
            return []

    _recs, peak = _peak(read_all)
    # Never more than the file and a few reads' worth of pieces, whatever the fields claim.
    assert peak < 4 * len(blob) + 4 * _MIB
    assert report.messages <= len(blob) // 22  # no message out of thin air

    # What replay gets: raw records with a finite time and bytes; never an exception;
    # what could not be read is counted in the source's health.
    from edged.logformats import UnknownFormat

    h = _health()
    try:
        raws = list(MCAP.open(_buffered(blob), "f", h, ReplayOptions()))
    except UnknownFormat:  # no readable record at all: refused like an empty file
        assert refused and isinstance(refused[0], NoRecords)
        return
    for r in raws:
        assert isinstance(r, RawRecord)
        assert isinstance(r.t, float) and math.isfinite(r.t)
        assert isinstance(r.data, bytes)
    if refused:
        assert raws == [] and h.counters["rejected.not_mcap"] == 1
    else:
        assert h.counters.get("rejected.bad_chunk", 0) == report.bad_chunks
        if report.truncated or report.error or not report.finished:
            assert h.counters.get("truncated", 0) + h.counters.get("damaged", 0) == 1
