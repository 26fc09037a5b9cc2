"""Every line-based log reader reads its lines with a bound (issue 32).

A 2 GB candump line took 4.3 GB of memory, a 512 MB Yacht Devices RAW line 1.18 GB.
Here each reader meets one endless line between good ones, at several sizes, from a
stream that makes its bytes as they are read (the test holds none of them): the good
lines all come through, the long one is counted `rejected.too_long` once, and the
reading holds a few hundred kilobytes however long the line is."""

from __future__ import annotations

import io
import tracemalloc

import pytest

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.loglines import MAX_LINE
from edged.plugin import ReplayOptions
from edged_can.logs import ACTISENSE_PLAIN, CANDUMP, IKONVERT, YDWG_RAW
from edged_nmea0183.logs import NMEA0183

GOOD = {
    "candump": b"(1732350000.000000) can0 09F80128#0102030405060708\n",
    "actisense_plain": b"2024-11-23T08:20:00.000Z,2,129025,40,255,8,01,02,03,04,05,06,07,08\n",
    "ydwg_raw": b"08:20:00.000 R 09F80128 01 02 03 04 05 06 07 08\n",
    "ikonvert": b"!PDGY,129025,2,40,255,482.213,AQIDBAUGBwg=\n",
    "nmea0183": b"$GPGLL,5400.000,N,01000.000,E,082000.00,A,A*63\n",
}
READERS = {"candump": CANDUMP, "actisense_plain": ACTISENSE_PLAIN, "ydwg_raw": YDWG_RAW,
           "ikonvert": IKONVERT, "nmea0183": NMEA0183}


class _Endless(io.RawIOBase):
    """`before` good lines, `size` bytes of 'A' without a line end, a line end, then
    `after` good lines: made as they are read."""

    def __init__(self, good: bytes, before: int, size: int, after: int) -> None:
        self.parts = [good * before, ("A", size), b"\n" + good * after]
        self.i, self.done = 0, 0

    def readable(self) -> bool:
        return True

    def readinto(self, b) -> int:  # type: ignore[override]
        while self.i < len(self.parts):
            part = self.parts[self.i]
            if isinstance(part, tuple):
                left = part[1] - self.done
                if left <= 0:
                    self.i, self.done = self.i + 1, 0
                    continue
                n = min(len(b), left)
                b[:n] = b"A" * n
                self.done += n
                return n
            left = part[self.done:]
            if not left:
                self.i, self.done = self.i + 1, 0
                continue
            n = min(len(b), len(left))
            b[:n] = left[:n]
            self.done += n
            return n
        return 0


@pytest.mark.parametrize("fmt", sorted(READERS))
@pytest.mark.parametrize("size", [MAX_LINE + 1, 10 << 20, 1 << 30])
def test_an_endless_line_is_counted_skipped_and_costs_no_memory(fmt, size):
    warm = ComponentHealth("w", "input", fmt, ManualClock(0.0))  # the reader's imports and caches
    list(READERS[fmt].open(io.BufferedReader(io.BytesIO(GOOD[fmt] * 2)), "w", warm, ReplayOptions(date="2024-11-23")))
    health = ComponentHealth("f", "input", fmt, ManualClock(0.0))
    stream = io.BufferedReader(_Endless(GOOD[fmt], 5, size, 5), 1 << 16)
    tracemalloc.start()
    try:
        records = list(READERS[fmt].open(stream, "f", health, ReplayOptions(date="2024-11-23")))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(records) == 10, (fmt, len(records), dict(health.counters))
    assert health.counters.get("rejected.too_long") == 1, dict(health.counters)
    assert peak < 4 << 20, peak  # bytes held at once, whatever the line's length


# -- fuzz: whatever the lines, no reader raises and every over-long one is counted once --
import os  # noqa: E402

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

EXAMPLES = int(os.environ.get("EDGED_FUZZ_EXAMPLES", "200"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

_LINE = st.one_of(
    st.sampled_from(list(GOOD.values())),  # a good line of some format
    st.binary(max_size=300).map(lambda b: b.replace(b"\n", b"") + b"\n"),  # garbage, one line
    st.integers(MAX_LINE - 2, MAX_LINE + 3).map(lambda n: b"A" * n + b"\n"),  # around the bound
    st.integers(MAX_LINE + 4, 3 * MAX_LINE).map(lambda n: b"$" * n + b"\n"),  # over it
)


@FUZZ
@given(fmt=st.sampled_from(sorted(READERS)), lines=st.lists(_LINE, max_size=12), tail=st.binary(max_size=40))
def test_fuzz_whatever_the_lines_every_reader_bounds_them(fmt, lines, tail):
    health = ComponentHealth("f", "input", fmt, ManualClock(0.0))
    data = b"".join(lines) + tail.replace(b"\n", b"")
    records = list(READERS[fmt].open(io.BufferedReader(io.BytesIO(data)), "f", health, ReplayOptions(date="2024-11-23")))
    too_long = sum(1 for ln in lines if len(ln) - 1 > MAX_LINE)  # its end not counted
    if fmt != "nmea0183":  # NMEA 0183's own splitter bounds at 1024 and counts its own way
        assert health.counters.get("rejected.too_long", 0) == too_long
    assert all(len(r.data) <= MAX_LINE for r in records)
