"""Issue 10, "Values that cannot be true pass": NMEA 0183 fields that cannot be true
are rejected (never wrapped into range), a bad magnetic variation is rejected by
itself, numbers are parsed strictly, and no angle leaves as −0.0.

The property-based part generates sentences of every supported type with random field
contents and a correct checksum, and asserts that whatever is emitted is valid,
finite, with angles in [0, 2π) and never −0.0. Its example count is
EDGED_FUZZ_EXAMPLES (default 200; tests/bench/bench_fuzz.py runs 20,000).
"""

from __future__ import annotations

import math
import os
from functools import reduce
from operator import xor

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from true_values import assert_true_values
from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.angles import TWO_PI, wrap_2pi
from edged.records import ANGLE_MAX, InvalidMeasurement, RawRecord, validate_measurement
from edged_nmea0183.decoder import DecoderSettings, Nmea0183Decoder
from edged_nmea0183.handlers import HANDLERS, count, num

T = 1_700_000_000.0
DEG = math.pi / 180
EXAMPLES = int(os.environ.get("EDGED_FUZZ_EXAMPLES", "200"))
FUZZ = settings(
    max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
    suppress_health_check=[HealthCheck.too_slow],
)


def _s(body: str) -> bytes:
    return b"$%s*%02X" % (body.encode(), reduce(xor, body.encode(), 0))


def _health() -> ComponentHealth:
    return ComponentHealth("gnss1", "input", "nmea0183", ManualClock(T))


class Rig:
    """One decoder over a sequence of sentences (state such as the variation spans them)."""

    def __init__(self, **settings) -> None:
        self.health = _health()
        self.dec = Nmea0183Decoder("gnss1", self.health, DecoderSettings(**settings))

    def __call__(self, body: str):
        return self.dec.decode(RawRecord("nmea0183", "gnss1", T, _s(body)))

    @property
    def c(self) -> dict[str, int]:
        return self.health.counters


def _positive_zero(x: float) -> bool:
    return x == 0.0 and math.copysign(1.0, x) == 1.0


# ---- item 1: angles beyond their range are rejected, not wrapped -------------------

@pytest.mark.parametrize("value", ["1e308", "-90", "360.1", "400", "-0.1", "nan", "inf", "1e2", "-1e300"])
def test_hdt_heading_out_of_range_or_not_a_number_is_rejected(value):
    rig = Rig()
    assert rig(f"GPHDT,{value},T") == []
    assert rig.c["invalid.HDT"] == 1 and "measurements.heading" not in rig.c


@pytest.mark.parametrize("stype", ["HDT", "THS"])
def test_true_heading_edges(stype):
    rig = Rig()
    tail = "A" if stype == "THS" else "T"
    (m,) = rig(f"GP{stype},360,{tail}")
    assert _positive_zero(m.values["heading"])  # 360 is north
    (m,) = rig(f"GP{stype},-0.0,{tail}")
    assert _positive_zero(m.values["heading"])  # never -0.0
    (m,) = rig(f"GP{stype},359.9,{tail}")
    assert m.values["heading"] == pytest.approx(359.9 * DEG)
    (m,) = rig(f"GP{stype},359.99999999999999,{tail}")  # rounds to 2π in radians
    assert m.values["heading"] < TWO_PI
    assert rig(f"GP{stype},360.5,{tail}") == []


@pytest.mark.parametrize("course", ["1e300", "-1e300", "361", "-10"])
def test_vtg_course_out_of_range_is_rejected(course):
    rig = Rig()
    assert rig(f"GPVTG,{course},T,,M,5.0,N,9.3,K,A") == []
    assert rig.c["invalid.VTG"] == 1


@pytest.mark.parametrize("course", ["400.0", "-10", "360.01"])
def test_rmc_course_out_of_range_rejects_the_velocity_only(course):
    rig = Rig()
    ms = rig(f"GPRMC,120000,A,5000.0000,N,00100.0000,E,5.0,{course},011123,,,A")
    assert [m.kind for m in ms] == ["position"]
    assert rig.c["invalid.RMC"] == 1


def test_rmc_course_not_a_number_rejects_the_sentence():
    rig = Rig()  # 1e300 is no NMEA decimal: the sentence is malformed
    assert rig("GPRMC,120000,A,5000.0000,N,00100.0000,E,5.0,1e300,011123,,,A") == []
    assert rig.c["invalid.RMC"] == 1


@pytest.mark.parametrize("set_", ["1e300", "360.5", "-1"])
def test_vdr_set_out_of_range_is_rejected(set_):
    rig = Rig()
    assert rig(f"IIVDR,{set_},T,,M,1.0,N") == []
    assert rig.c["invalid.VDR"] == 1


def test_vdr_magnetic_set_plus_variation_is_wrapped_and_bounded():
    rig = Rig(variation=20.0)
    (m,) = rig("IIVDR,,T,350,M,1.0,N")
    assert m.values["set"] == pytest.approx(10 * DEG)
    assert rig("IIVDR,,T,1e300,M,1.0,N") == []


@pytest.mark.parametrize("body", [
    "HCHDM,1e300,M", "HCHDM,-5,M", "HCHDG,400,,,,", "HCHDG,100,200,E,,", "HCHDG,100,1,E,181,W",
])
def test_magnetic_headings_out_of_range_are_rejected(body):
    rig = Rig(variation=2.0)
    assert rig(body) == []
    assert rig.c[f"invalid.{body[2:5]}"] == 1


def test_rate_of_turn_has_any_sign():
    rig = Rig()
    (m,) = rig("TIROT,-35.2,A")
    assert m.values["r"] == pytest.approx(-35.2 * DEG / 60)


def test_wrap_2pi_never_gives_minus_zero_or_two_pi():
    for a in (-0.0, -1e-300, 0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, math.nextafter(0.0, -1.0)):
        w = wrap_2pi(a)
        assert 0.0 <= w < TWO_PI and math.copysign(1.0, w) == 1.0, (a, w)


def test_angle_bound_excludes_two_pi():
    validate_measurement("heading", {"heading": ANGLE_MAX})
    with pytest.raises(InvalidMeasurement):
        validate_measurement("heading", {"heading": TWO_PI})


def test_position_on_the_equator_and_meridian_is_positive_zero():
    (m,) = Rig()("GPGGA,120000,0000.0000,S,00000.0000,W,1,08,0.9,10.0,M,,,,")
    assert all(_positive_zero(m.values[k]) for k in ("lat", "lon")), m.values


# ---- item 2: a bad magnetic variation is rejected by itself ------------------------

@pytest.mark.parametrize("var", ["nan,E", "200.0,E", "181,W", "1_0,E", "5.0,X"])
def test_rmc_bad_variation_is_rejected_alone_and_the_good_one_kept(var):
    rig = Rig(variation=-3.0)
    rmc = f"GPRMC,120000,A,5000.0000,N,00100.0000,E,5.0,90.0,011123,{var},A"
    ms = rig(rmc)
    assert sorted(m.kind for m in ms) == ["position", "velocity_ground"]  # the fix stays
    assert rig.c["invalid.RMC.variation"] == 1 and "invalid.RMC" not in rig.c
    (h,) = rig("HCHDM,100.0,M")  # the configured variation is still in use
    assert h.kind == "heading" and h.values["heading"] == pytest.approx(97 * DEG)
    (g,) = rig("HCHDG,100.0,,,,")
    assert g.kind == "heading" and g.values["heading"] == pytest.approx(97 * DEG)
    (v,) = rig("IIVDR,,T,100,M,1.0,N")
    assert v.values["set"] == pytest.approx(97 * DEG)
    assert "invalid.HDM" not in rig.c and "invalid.HDG" not in rig.c and "invalid.VDR" not in rig.c


def test_rmc_bad_variation_keeps_the_last_good_one():
    rig = Rig()
    rig("GPRMC,120000,A,5000.0000,N,00100.0000,E,5.0,90.0,011123,4.0,E,A")
    rig("GPRMC,120001,A,5000.0000,N,00100.0000,E,5.0,90.0,011123,nan,E,A")
    (h,) = rig("HCHDM,100.0,M")
    assert h.kind == "heading" and h.values["heading"] == pytest.approx(104 * DEG)


def test_rmc_bad_variation_without_any_known_leaves_headings_magnetic():
    rig = Rig()
    rig("GPRMC,120000,A,5000.0000,N,00100.0000,E,5.0,90.0,011123,nan,E,A")
    (h,) = rig("HCHDM,100.0,M")
    assert h.kind == "heading_magnetic" and "invalid.HDM" not in rig.c


def test_bad_variation_is_logged_once():
    rig = Rig()
    for v in ("200", "300", "nan"):
        rig(f"GPRMC,120000,A,5000.0000,N,00100.0000,E,5.0,90.0,011123,{v},E,A")
    assert rig.c["invalid.RMC.variation"] == 3
    assert rig.health.last_error is not None and "variation" in rig.health.last_error


def test_hdg_bad_own_variation_rejects_that_hdg_only():
    rig = Rig(variation=1.0)
    assert rig("HCHDG,100.0,,,nan,E") == []
    assert rig("HCHDG,100.0,,,190,E") == []
    (h,) = rig("HCHDM,100.0,M")
    assert h.values["heading"] == pytest.approx(101 * DEG)


# ---- item 3: fix quality, DPT offset, strict numbers -------------------------------

@pytest.mark.parametrize("q", ["99", "9", "-1", "1_0", " 1"])
def test_gga_fix_quality_outside_0_8_is_rejected(q):
    rig = Rig()
    assert rig(f"GPGGA,120000,5000.0000,N,00100.0000,E,{q},08,0.9,10.0,M,,,,") == []
    assert rig.c["invalid.GGA"] == 1


def test_gga_fix_quality_8_is_kept():
    (m,) = Rig()("GPGGA,120000,5000.0000,N,00100.0000,E,8,08,0.9,10.0,M,,,,")
    assert m.values["fix_quality"] == 8


@pytest.mark.parametrize("offset", ["1e300", "100.5", "-101", "nan"])
def test_dpt_offset_is_bounded(offset):
    rig = Rig()
    assert rig(f"SDDPT,12.5,{offset},") == []
    assert rig.c["invalid.DPT"] == 1


def test_dpt_plausible_offset_is_kept():
    (m,) = Rig()("SDDPT,12.5,-2.5,")
    assert m.values == {"depth": 12.5, "offset": -2.5}


@pytest.mark.parametrize("text", ["1_0", " 10 ", "10 ", " 10", "1e1", "nan", "inf", "+inf", "0x10", "", ".", "-", "1.2.3", "5-", "+-5", "--5", "1+2"])
def test_strict_number_parser_refuses_what_python_accepts(text):
    with pytest.raises(ValueError):
        num(text)


@pytest.mark.parametrize("text,value", [("10", 10.0), ("-3.5", -3.5), ("+2", 2.0), (".5", 0.5), ("5.", 5.0), ("007", 7.0)])
def test_strict_number_parser_reads_nmea_decimals(text, value):
    assert num(text) == value


@pytest.mark.parametrize("text", ["1_0", " 10", "10 ", "-1", "+1", "1.0", ""])
def test_strict_integer_parser(text):
    with pytest.raises(ValueError):
        count(text)


@pytest.mark.parametrize("body", [
    "GPHDT,1_0,T", "GPHDT, 10 ,T", "SDDBT,,f,1_0,M,,F", "TIROT,1_0,A", "VWVHW,,T,,M, 5.0,N,,K",
    "GPGGA,120000,5000.0000,N,00100.0000,E,1,1_2,0.9,10.0,M,,,,",
    "GPVTG,90.0,T,,M,1_0,N,,K,A",
])
def test_sentences_with_python_only_numbers_are_malformed(body):
    rig = Rig()
    assert rig(body) == []
    assert sum(v for k, v in rig.c.items() if k.startswith("invalid.")) == 1


def test_fix_quality_and_offset_bounds_in_the_kinds():
    with pytest.raises(InvalidMeasurement):
        validate_measurement("position", {"lat": 1.0, "lon": 1.0, "fix_quality": 9})
    with pytest.raises(InvalidMeasurement):
        validate_measurement("depth", {"depth": 1.0, "offset": 1e300})


# ---- item 5: property-based fuzzing of every supported sentence type ---------------

#: The values of issue 10 and other edges, drawn as often as all random numbers.
_EDGES = st.sampled_from([
    "", "-0", "-0.0", "360", "360.0", "359.99999999999999", "0", "1_0", " 10 ", "nan", "inf",
    "1e308", "-90", "99", "9", "181", "-181", "1e300", "100.5",
])
_NUMBERISH = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(-1e4, 1e4).map(lambda x: f"{x:.3f}"),
    st.integers(-1000, 100000).map(str),
)
_LETTER = st.sampled_from(["", "A", "V", "N", "S", "E", "W", "T", "M", "K", "F", "f", "D", "R", "P"])
_FIELD = st.one_of(_EDGES, _NUMBERISH, _LETTER, st.text(alphabet="0123456789.-+ENSWAVTM_", max_size=10))
#: A valid sentence of every supported type, which the fuzzer mutates field by field
#: (random fields alone would hardly ever make a position).
_TEMPLATES = {
    "GGA": "120000,5000.0000,N,00100.0000,E,1,08,0.9,10.0,M,46.0,M,,",
    "GNS": "120000.00,5000.0000,N,00100.0000,E,AA,10,0.9,10.0,40.0,,",
    "RMC": "120000,A,5000.0000,N,00100.0000,E,5.0,90.0,011123,2.0,E,A",
    "GLL": "5000.0000,N,00100.0000,E,120000,A,A",
    "VTG": "90.0,T,88.0,M,5.0,N,9.3,K,A",
    "HDT": "90.0,T",
    "THS": "90.0,A",
    "HDG": "90.0,1.0,E,2.0,W",
    "HDM": "90.0,M",
    "ROT": "-3.5,A",
    "VBW": "5.0,0.1,A,5.1,0.2,A",
    "VHW": "90.0,T,88.0,M,5.0,N,9.3,K",
    "VDR": "90.0,T,88.0,M,1.0,N",
    "DPT": "12.5,-2.5,",
    "DBT": "41.0,f,12.5,M,6.8,F",
    "ZDA": "120000.00,01,11,2023,00,00",
}
assert set(_TEMPLATES) == set(HANDLERS), "a new sentence type needs a fuzz template"
_TYPES = sorted(HANDLERS)


@st.composite
def _sentence(draw) -> tuple[str, bytes]:
    """A valid sentence of a random type with random fields replaced (or cut, or added)."""
    stype = draw(st.sampled_from(_TYPES))
    fields = _TEMPLATES[stype].split(",")
    for i in range(len(fields)):
        if draw(st.integers(0, 3)) == 0:
            fields[i] = draw(_FIELD)
    cut = draw(st.integers(-2, 1))
    fields = fields[: len(fields) + cut] if cut < 0 else fields + [draw(_FIELD)] * cut
    talker = draw(st.sampled_from(["GP", "GN", "HE", "II"]))
    return stype, _s(",".join([talker + stype] + fields))


_check_emitted = assert_true_values


def _check_true_heading(stype: str, line: bytes, ms) -> None:
    """Oracle for HDT/THS: a heading comes only from a field in [0, 360], unwrapped."""
    if stype not in ("HDT", "THS") or not ms:
        return
    deg = float(line.decode().split("*")[0].split(",")[1])
    assert 0.0 <= deg <= 360.0, (line, ms)
    if deg < 360.0:
        assert ms[0].values["heading"] == pytest.approx(math.radians(deg), abs=1e-12), (line, ms)


@FUZZ
@given(batch=st.lists(_sentence(), min_size=1, max_size=8), variation=st.sampled_from([None, -3.0, 179.5]))
@example(batch=[("HDT", _s("GPHDT,-0,T")), ("HDT", _s("GPHDT,400,T"))], variation=None)
@example(
    batch=[("RMC", _s("GPRMC,120000,A,5000.0000,N,00100.0000,E,5.0,90.0,011123,nan,E,A")),
           ("HDM", _s("HCHDM,100.0,M"))],
    variation=-3.0,
)
def test_fuzz_every_sentence_type_emits_only_true_values(batch, variation):
    health = _health()
    dec = Nmea0183Decoder("gnss1", health, DecoderSettings(variation=variation))
    for stype, line in batch:
        ms = dec.decode(RawRecord("nmea0183", "gnss1", T, line))
        _check_emitted(ms)
        _check_true_heading(stype, line, ms)
    assert "decode_errors" not in health.counters
    # The decoder's own variation stays usable whatever RMC/HDG said.
    v = dec._env.variation
    assert v is None or -180.0 <= v <= 180.0
