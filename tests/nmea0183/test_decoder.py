"""Decoding every supported sentence type into SI measurements (real-world samples)."""

from __future__ import annotations

import math

import pynmea2
import pytest

from edged.records import RawRecord, validate_measurement
from edged_nmea0183.decoder import DecoderSettings, Nmea0183Decoder

T = 1_534_758_457.0  # 2018-08-20T09:47:37Z
KN = 1852 / 3600
DEG = math.pi / 180


def decode(line: str, health, t: float = T, **settings):
    dec = Nmea0183Decoder("gnss1", health, DecoderSettings(**settings))
    return dec.decode(RawRecord("nmea0183", "gnss1", t, line.encode()))


def one(line: str, health, **settings):
    ms = decode(line, health, **settings)
    assert len(ms) == 1, ms
    m = ms[0]
    validate_measurement(m.kind, m.values)
    assert m.source == "gnss1" and m.t == T
    return m


# Real sentences from the shared logs (file named) or the quoted device manual.
def test_gga_bundg_zeus(health):
    line = "$GPGGA,094736,5251.0094,N,00518.8172,E,1,12,0.60,-4,M,46.8,M,,*4B"
    m = one(line, health)
    assert m.kind == "position"
    ref = pynmea2.parse(line, check=True)  # pynmea2's typed reading is the oracle
    assert m.values["lat"] == pytest.approx(ref.latitude, abs=1e-9)
    assert m.values["lon"] == pytest.approx(ref.longitude, abs=1e-9)
    assert m.values["fix_quality"] == 1 and m.values["sats"] == 12 and m.values["hdop"] == 0.6
    assert m.t_src == T - 1  # 09:47:36 on the record's day
    assert health.counters["sentences.GGA"] == 1 and health.counters["measurements.position"] == 1


def test_gga_southern_western_hemispheres(health, nmea):
    m = one(nmea("INGGA,194104,4426.1138,S,07140.5536,W,2,10,0.9,267.9,M,,,,"), health)
    assert m.values["lat"] == pytest.approx(-(44 + 26.1138 / 60))
    assert m.values["lon"] == pytest.approx(-(71 + 40.5536 / 60))


def _cs(body: str) -> str:
    from functools import reduce
    from operator import xor

    return "*%02X" % reduce(xor, body.encode(), 0)


def test_gns(health, nmea):
    line = nmea("GNGNS,014035.00,4332.69262,S,17235.48549,E,RR,13,0.9,25.63,11.24,,")
    m = one(line, health)
    assert m.kind == "position" and m.values["fix_quality"] == 4  # RTK fixed
    assert m.values["lat"] == pytest.approx(-(43 + 32.69262 / 60))


def test_rmc_position_velocity_and_variation(health):
    line = "$GPRMC,094737,A,5251.0093,N,00518.8170,E,5.6,230.5,200818,1.4,E,A*1F"
    ms = decode(line, health)
    pos, vel = ms
    assert pos.kind == "position" and vel.kind == "velocity_ground"
    assert vel.values["sog"] == pytest.approx(5.6 * KN)
    assert vel.values["cog"] == pytest.approx(230.5 * DEG)
    assert pos.t_src == T


def test_gll_and_vtg_humminbird(health):
    gll = one("$INGLL,4426.1130,N,07140.5579,W,194102,A*2C", health)
    assert gll.values["lon"] == pytest.approx(-(71 + 40.5579 / 60))
    vtg = one("$INVTG,77.5,T,93.3,M,5.2,N,9.7,K*5B", health)
    assert vtg.values == pytest.approx({"sog": 5.2 * KN, "cog": 77.5 * DEG})


def test_vtg_kmh_only(health, nmea):
    m = one(nmea("GPVTG,10.0,T,,M,,N,36.0,K,A"), health)
    assert m.values["sog"] == pytest.approx(10.0)


def test_hdt_and_rot_saab_gyro(health):
    hdt = one("$HEHDT,274.07,T*19", health)
    assert hdt.kind == "heading" and hdt.values["heading"] == pytest.approx(274.07 * DEG)
    rot = one("$HEROT,-1.2,A" + _cs("HEROT,-1.2,A"), health)
    assert rot.kind == "yaw_rate" and rot.values["r"] == pytest.approx(-1.2 * DEG / 60)  # to port


def test_ths_skytraq(health):
    m = one("$GNTHS,244.67,A" + _cs("GNTHS,244.67,A"), health)
    assert m.kind == "heading" and m.values["heading"] == pytest.approx(244.67 * DEG)
    # pynmea2 reads THS too once the package is imported (the subclass registers it)
    assert float(pynmea2.parse("$GNTHS,244.67,A" + _cs("GNTHS,244.67,A")).heading) == 244.67


def test_hdg_uses_its_own_variation_and_deviation(health):
    m = one("$SDHDG,229.8,,,1.3,E*36", health)  # bundg_zeus_9: variation 1.3 E
    assert m.kind == "heading" and m.values["heading"] == pytest.approx(231.1 * DEG)
    m = one("$HCHDG,98.3,0.5,W,2.0,W" + _cs("HCHDG,98.3,0.5,W,2.0,W"), health)
    assert m.values["heading"] == pytest.approx((98.3 - 0.5 - 2.0) * DEG)


def test_heading_variation_order_sentence_then_rmc_then_config(health, nmea):
    dec = Nmea0183Decoder("c", health, DecoderSettings(variation=-3.0))
    rec = lambda line: RawRecord("nmea0183", "c", T, line.encode())  # noqa: E731
    (m,) = dec.decode(rec(nmea("APHDM,100.0,M")))
    assert m.kind == "heading" and m.values["heading"] == pytest.approx(97.0 * DEG)  # config
    dec.decode(rec(nmea("GPRMC,094737,A,5251.0093,N,00518.8170,E,5.6,230.5,200818,1.4,E,A")))
    (m,) = dec.decode(rec(nmea("APHDM,100.0,M")))
    assert m.values["heading"] == pytest.approx(101.4 * DEG)  # RMC outranks config
    (m,) = dec.decode(rec(nmea("SDHDG,100.0,,,5.0,W")))
    assert m.values["heading"] == pytest.approx(95.0 * DEG)  # the sentence's own first


def test_hdm_without_variation_is_magnetic(health):
    m = one("$APHDM,218.634,M*39", health)  # pypilot.log
    assert m.kind == "heading_magnetic" and m.values["heading"] == pytest.approx(218.634 * DEG)
    m = one("$24HDG,10.0,,,,*" + _cs("24HDG,10.0,,,,")[1:], health)  # numeric talker (n2kd)
    assert m.kind == "heading_magnetic"


def test_heading_wraps_into_0_2pi(health, nmea):
    m = one(nmea("HCHDG,359.5,,,1.0,E"), health)
    assert m.values["heading"] == pytest.approx(0.5 * DEG)


def test_vbw_water_part_and_optional_ground_part(health, nmea):
    line = nmea("VDVBW,6.20,-0.15,A,6.40,0.10,A")
    (w,) = decode(line, health)
    assert w.kind == "water_speed"
    assert w.values == pytest.approx({"stw_long": 6.2 * KN, "stw_trans": -0.15 * KN})
    w, g = decode(line, health, vbw_ground=True)
    assert g.kind == "velocity_ground" and g.values["sog"] == pytest.approx(math.hypot(6.4, 0.1) * KN)
    (g,) = decode(nmea("VDVBW,,,V,6.40,0.10,A"), health, vbw_ground=True)
    assert g.kind == "velocity_ground"


def test_vhw_knots_and_kmh(health):
    m = one("$SDVHW,231.3,T,229.9,M,6.6,N,12.3,K*71", health)
    assert m.kind == "water_speed" and m.values["stw_long"] == pytest.approx(6.6 * KN)
    m = one("$IIVHW,,T,,M,,N,11.31,K" + _cs("IIVHW,,T,,M,,N,11.31,K"), health)
    assert m.values["stw_long"] == pytest.approx(11.31 / 3.6)


def test_vdr_current(health, nmea):
    m = one(nmea("IIVDR,45.0,T,40.0,M,1.5,N"), health)
    assert m.kind == "current" and m.values == pytest.approx({"set": 45 * DEG, "drift": 1.5 * KN})


def test_dpt_and_dbt(health):
    m = one("$SDDPT,5.3,0.4,*79", health)
    assert m.kind == "depth" and m.values == {"depth": 5.3, "offset": 0.4}
    m = one("$SDDBT,16.1,f,4.9,M,2.7,F" + _cs("SDDBT,16.1,f,4.9,M,2.7,F"), health)
    assert m.values["depth"] == 4.9
    m = one("$SDDBT,16.4,f,,M,,F" + _cs("SDDBT,16.4,f,,M,,F"), health)
    assert m.values["depth"] == pytest.approx(16.4 * 0.3048)


def test_zda_counts_but_emits_nothing(health):
    assert decode("$GPZDA,094737,20,08,2018,-01,00*6B", health) == []
    assert health.counters["sentences.ZDA"] == 1


@pytest.mark.parametrize(
    "body, stype",
    [
        ("GPGGA,,,,,,0,,,,M,,M,,", "GGA"),  # hemi.log: no fix
        ("GPGGA,094736,5251.0094,N,00518.8172,E,0,12,0.60,-4,M,46.8,M,,", "GGA"),  # quality 0
        ("GPRMC,094737,V,5251.0093,N,00518.8170,E,5.6,230.5,200818,1.4,E,N", "RMC"),
        ("GPRMC,094737,A,5251.0093,N,00518.8170,E,5.6,230.5,200818,1.4,E,N", "RMC"),  # FAA N
        ("GPGLL,5251.0093,N,00518.8170,E,094736,V,N", "GLL"),
        ("GPVTG,,T,,M,,N,,K,N", "VTG"),
        ("GPVTG,10.0,T,,M,,N,,K,A", "VTG"),  # no speed at all
        ("GPHDT,,T", "HDT"),  # hemi.log / plaka.log: empty
        ("GNTHS,244.67,V", "THS"),
        ("GNTHS,244.67,S", "THS"),  # simulator
        ("IIHDM,,M", "HDM"),
        ("SDHDG,,,,,", "HDG"),
        ("HEROT,-1.2,V", "ROT"),
        ("VDVBW,6.2,0.1,V,6.4,0.1,V", "VBW"),
        ("IIVHW,,T,,M,,N,,K", "VHW"),
        ("IIVDR,,T,,M,,N", "VDR"),  # plaka.log: all empty
        ("SDDPT,,", "DPT"),
        ("SDDBT,,f,,M,,F", "DBT"),
        ("GNGNS,014035.00,4332.69262,S,17235.48549,E,NN,13,0.9,25.63,11.24,,", "GNS"),
        ("GPGGA,094736,9951.0094,N,00518.8172,E,1,12,0.60,-4,M,46.8,M,,", "GGA"),  # lat > 90
        ("GPGGA,094736,5275.0000,N,00518.8172,E,1,12,0.60,-4,M,46.8,M,,", "GGA"),  # 75 minutes
        ("GPGGA,094736,5251.0094,X,00518.8172,E,1,12,0.60,-4,M,46.8,M,,", "GGA"),  # hemisphere
        ("GPVTG,10.0,T,,M,-5.0,N,,K,A", "VTG"),  # negative speed
        ("SDDPT,-3.0,0.4,", "DPT"),  # negative depth
        ("GPGGA,094736,5251.0094", "GGA"),  # truncated
        ("GPVTG,10.0,T,,M,nan,N,,K,A", "VTG"),
    ],
)
def test_invalid_sentences_give_nothing_and_are_counted(body, stype, health, nmea):
    assert decode(nmea(body), health) == []
    assert health.counters[f"invalid.{stype}"] == 1
    assert health.counters[f"sentences.{stype}"] == 1
    assert not any(k.startswith("measurements.") for k in health.counters)


def test_invalid_logged_once_per_kind_of_problem(health, nmea):
    dec = Nmea0183Decoder("c", health)
    for _ in range(100):
        dec.decode(RawRecord("nmea0183", "c", T, nmea("GPHDT,,T").encode()))
        dec.decode(RawRecord("nmea0183", "c", T, nmea("GPGGA,,,,,,0,,,,M,,M,,").encode()))
    assert health.counters["invalid.HDT"] == 100 and health.counters["invalid.GGA"] == 100
    assert health.counters["errors"] == 2


@pytest.mark.parametrize(
    "line, key",
    [
        ("!AIVDM,1,1,,A,13aEOK?P00PD2wVMdLDRhgvL289?,0*26", "encapsulated.VDM"),
        ("$WIMWV,57.5,R,13.0,N,A*26", "unknown.MWV"),
        ("$02MWV,57.5,R,13.0,N,A" + _cs("02MWV,57.5,R,13.0,N,A"), "unknown.MWV"),
        ("$PASHR,204132.000,010.51,T,+00.39,-00.79,-00.84,0.151,0.075,0.555,1,0*03", "unknown.PASHR"),
        ("$PGRME,15.0,M,45.0,M,25.0,M*1C", "unknown.PGRME"),
        ("$,,," + _cs(",,,"), "malformed"),
        ("$GP" + _cs("GP"), "malformed"),
    ],
)
def test_not_decoded_sentences_are_counted(line, key, health):
    assert decode(line, health) == []
    assert health.counters[key] == 1


def test_decoder_strips_a_tag_block_left_in_the_data(health):
    ms = decode("\\c:1700000000*04\\$HEHDT,274.07,T*19", health)
    assert [m.kind for m in ms] == ["heading"]


def test_unknown_counter_names_are_bounded(health, nmea):
    dec = Nmea0183Decoder("c", health)
    for i in range(200):
        dec.decode(RawRecord("nmea0183", "c", T, nmea(f"GP{i:03d},1").encode()))
    assert len([k for k in health.counters if k.startswith("unknown.")]) <= 65
    assert sum(v for k, v in health.counters.items() if k.startswith("unknown.")) == 200


def test_decoder_failure_is_counted_not_raised(health, monkeypatch):
    dec = Nmea0183Decoder("c", health)

    def broken(f, env):
        raise RuntimeError("bug")

    monkeypatch.setattr(dec._types["HDT"], "handler", broken)
    assert dec.decode(RawRecord("nmea0183", "c", T, b"$HEHDT,274.07,T*19")) == []
    assert health.counters["decode_errors"] == 1


def test_a_sentence_with_an_own_outputs_talker_is_refused_not_decoded(health, nmea):
    """No loops (issue 35): the talker IDs edged's own NMEA 0183 outputs send reach the
    decoder as marks; their sentences count `rejected.own_output` and make nothing,
    while the same sentence from another talker is decoded."""
    from edged.plugin import own_marks_of
    from edged_nmea0183.decoder import OWN_TALKER

    class Out:
        @classmethod
        def own_marks(cls, config):
            return {OWN_TALKER: {config}}

    marks = own_marks_of([(Out, "ED"), (Out, "XY")])
    assert marks == {OWN_TALKER: frozenset({"ED", "XY"})}
    settings = DecoderSettings.from_config(None, marks)
    dec = Nmea0183Decoder("bridge", health, settings)
    assert dec.decode(RawRecord("nmea0183", "bridge", T, nmea("EDHDT,123.4,T").encode())) == []
    assert dec.decode(RawRecord("nmea0183", "bridge", T, nmea("XYHDT,123.4,T").encode())) == []
    assert health.counters["rejected.own_output"] == 2
    assert len(dec.decode(RawRecord("nmea0183", "bridge", T, nmea("HEHDT,123.4,T").encode()))) == 1
    assert "sentences.HDT" in health.counters and health.counters["rejected.own_output"] == 2
