"""Property-based fuzzing: no byte input makes framing or decoding raise, and the
counters add up (lines == accepted + rejected.*)."""

from __future__ import annotations

import io
from functools import reduce
from operator import xor

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import RawRecord, validate_measurement
from edged_nmea0183.framer import Framer
from edged_nmea0183.lines import Framed, LineSplitter, frame
from edged_nmea0183.handlers import HANDLERS
from edged_nmea0183.logs import NMEA0183
from edged_nmea0183.plugin import Nmea0183Input

FUZZ = settings(max_examples=300, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])


def _health() -> ComponentHealth:
    return ComponentHealth("f", "input", "nmea0183", ManualClock())


def _sum(c: dict[str, int], prefix: str) -> int:
    return sum(v for k, v in c.items() if k.startswith(prefix))


_field = st.text(alphabet="0123456789.,-+NSEWATVMKNfF *$!\\:", max_size=12)


@st.composite
def sentences(draw) -> bytes:
    """Near-valid sentences: a known type, random fields, usually a right checksum."""
    stype = draw(st.sampled_from(sorted(HANDLERS) + ["MWV", "GSV"]))
    talker = draw(st.sampled_from(["GP", "GN", "II", "HE", "24", "P"]))
    body = ",".join([talker + stype] + draw(st.lists(_field, max_size=16)))
    cs = reduce(xor, body.encode(), 0)
    if draw(st.booleans()):
        cs ^= draw(st.integers(0, 255))
    start = draw(st.sampled_from([
        "$", "$", "!", "", "\\c:1700000000*04\\$", "1700000000 $",
        # TAG blocks with right checksums: their sentences take the chunk's fast checksum
        "\\c:1700000000*5F\\$", "\\s:gnss,c:1700000000.5*28\\$",
    ]))
    end = draw(st.sampled_from(["\r\n", "\n", "\r", ""]))
    return f"{start}{body}*{cs:02X}{end}".encode()


lines_strategy = st.lists(st.one_of(st.binary(max_size=80), sentences()), max_size=40)


@FUZZ
@given(chunks=lines_strategy, policy=st.sampled_from(["require", "allow-missing", "ignore"]))
def test_framer_never_raises_and_counts_add_up(chunks, policy):
    health = _health()
    f = Framer(health, policy)
    accepted = 0
    for c in chunks:
        accepted += len(f.feed(c))
    accepted += len(f.flush())
    c = health.counters
    assert c.get("lines", 0) == accepted + _sum(c, "rejected.")


@FUZZ
@given(chunks=lines_strategy, date=st.sampled_from([None, "2024-02-29"]))
def test_replay_and_decode_never_raise_and_counts_add_up(chunks, date):
    health = _health()
    dec = Nmea0183Input.make_decoder("f", None, health)
    data = b"".join(chunks)
    raws = list(NMEA0183.open(io.BytesIO(data), "f", health, ReplayOptions(date=date)))
    n_meas = 0
    for r in raws:
        for m in dec.decode(r):
            validate_measurement(m.kind, m.values)  # nothing impossible gets out
            n_meas += 1
    c = health.counters
    assert c.get("lines", 0) == c.get("accepted", 0) + _sum(c, "rejected.") == len(raws) + _sum(c, "rejected.")
    assert _sum(c, "measurements.") == n_meas
    assert "decode_errors" not in c


@FUZZ
@given(data=st.one_of(st.binary(max_size=200), sentences()), t=st.floats(allow_nan=True, allow_infinity=True))
def test_decoder_never_raises_on_any_record(data, t):
    health = _health()
    dec = Nmea0183Input.make_decoder("f", None, health)
    for m in dec.decode(RawRecord("nmea0183", "f", t, data)):
        validate_measurement(m.kind, m.values)
    assert "decode_errors" not in health.counters


@FUZZ
@given(items=st.lists(st.one_of(st.binary(max_size=80), sentences()), min_size=8, max_size=40),
       policy=st.sampled_from(["require", "allow-missing"]))
def test_chunk_checksums_judge_as_line_by_line(items, policy):
    """A chunk's checksums are computed at once (numpy); the verdicts must be those of
    `frame` on each line alone, whatever the whitespace, TAG blocks or prefixes."""
    data = b"\n".join(items) + b"\n"
    alone = [r for r in map(lambda line: frame(line, policy), LineSplitter().feed(data)) if isinstance(r, Framed)]
    assert Framer(_health(), policy).feed(data) == alone
