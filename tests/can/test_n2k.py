"""NMEA 2000 PGNs -> measurements: identifiers, values, "not available", naming, rejects."""

from __future__ import annotations

import math
import struct

import pytest

from edged.records import RawRecord
from edged_can import n2k_codec


@pytest.mark.parametrize(
    "can_id, expected",
    [
        (0x09F10D0B, (2, 127245, 0x0B, 255)),  # PDU2: PS is part of the PGN
        (0x09F8017F, (2, 129025, 0x7F, 255)),
        (0x18EEFF01, (6, 60928, 0x01, 255)),  # PDU1 broadcast: PS is the destination
        (0x18EA2301, (6, 59904, 0x01, 0x23)),  # PDU1 addressed: PS = destination 0x23
        (0x1DEFFFCC, (7, 126720, 0xCC, 255)),  # data page bit set: PGN 0x1EF00
    ],
)
def test_identifier_gives_priority_pgn_source_destination(can_id, expected):
    assert n2k_codec.split_id(can_id) == expected


def test_true_heading(feed, build):
    (m,) = feed((build.n2k_id(127250, 28), build.pgn_127250(math.radians(271.5))))
    assert (m.kind, m.source, m.t) == ("heading", "can0.28", 100.0)
    assert m.values["heading"] == pytest.approx(math.radians(271.5), abs=1e-4)


def test_magnetic_heading_with_variation_in_the_same_pgn_becomes_true(feed, build):
    data = build.pgn_127250(math.radians(10.0), deviation=math.radians(1.0), variation=math.radians(-15.0), ref=1)
    (m,) = feed((build.n2k_id(127250, 28), data))
    assert m.kind == "heading"
    # 10 + 1 - 15 = -4 deg -> 356 deg, wrapped into [0, 2pi)
    assert m.values["heading"] == pytest.approx(math.radians(356.0), abs=2e-4)


def test_magnetic_heading_without_variation_stays_magnetic(feed, build):
    (m,) = feed((build.n2k_id(127250, 28), build.pgn_127250(math.radians(10.0), ref=1)))
    assert m.kind == "heading_magnetic"
    assert m.values["heading"] == pytest.approx(math.radians(10.0), abs=1e-4)


def test_variation_from_pgn_127258_makes_magnetic_heading_true(feed, build):
    var = struct.pack("<BBHhH", 0, 0xF1, 0xFFFF, round(math.radians(5.0) / 1e-4), 0xFFFF)
    ms = feed(
        (build.n2k_id(127258, 40), var),
        (build.n2k_id(127250, 28), build.pgn_127250(math.radians(10.0), ref=1)),
    )
    assert [m.kind for m in ms] == ["heading"]
    assert ms[0].values["heading"] == pytest.approx(math.radians(15.0), abs=2e-4)


def test_configured_variation_is_the_last_resort(make_decoder, build):
    dec = make_decoder(magnetic_variation_deg=-3.0)
    (m,) = dec.decode(build.raw(build.n2k_id(127250, 28), build.pgn_127250(math.radians(10.0), ref=1)))
    assert m.kind == "heading"
    assert m.values["heading"] == pytest.approx(math.radians(7.0), abs=2e-4)


def test_heading_not_available_gives_no_measurement(feed, health, build):
    data = struct.pack("<BHhhB", 0, 0xFFFF, 0x7FFF, 0x7FFF, 0xFC)
    assert feed((build.n2k_id(127250, 28), data)) == []
    assert health.counters["unavailable.127250"] == 1
    assert health.counters["pgn.127250"] == 1


def test_heading_with_an_error_reference_is_rejected(feed, health, build):
    assert feed((build.n2k_id(127250, 28), build.pgn_127250(1.0, ref=2))) == []
    assert health.counters["rejected.heading_reference"] == 1
    assert "127250" in health.last_error


def test_rate_of_turn(feed, build):
    r = 0.05  # rad/s, to starboard
    (m,) = feed((build.n2k_id(127251, 28), struct.pack("<Bi", 0, round(r / 3.125e-8)) + b"\xff" * 3))
    assert (m.kind, m.values["r"]) == ("yaw_rate", pytest.approx(r, abs=1e-7))


def test_attitude(feed, build):
    data = struct.pack("<BhhhB", 0, 0x7FFF, round(0.02 / 1e-4), round(-0.1 / 1e-4), 0xFF)
    (m,) = feed((build.n2k_id(127257, 28), data))
    assert m.kind == "attitude"
    assert m.values == {"roll": pytest.approx(-0.1), "pitch": pytest.approx(0.02)}


def test_speed_through_water(feed, build):
    data = struct.pack("<BHHBB", 0, 612, 0xFFFF, 0, 0xFF) + b"\xff"
    (m,) = feed((build.n2k_id(128259, 35), data))
    assert (m.kind, m.source, m.values) == ("water_speed", "can0.35", {"stw_long": pytest.approx(6.12)})


def test_water_depth_with_offset(feed, build):
    data = struct.pack("<BIhB", 0, 1234, -500, 0xFF)
    (m,) = feed((build.n2k_id(128267, 35), data))
    assert m.kind == "depth"
    assert m.values == {"depth": pytest.approx(12.34), "offset": pytest.approx(-0.5)}


def test_water_depth_not_available(feed, health, build):
    assert feed((build.n2k_id(128267, 35), struct.pack("<BIhB", 0, 0xFFFFFFFF, 0x7FFF, 0xFF))) == []
    assert health.counters["unavailable.128267"] == 1


def test_position_rapid_update(feed, build):
    data = struct.pack("<ii", round(-33.8688 / 1e-7), round(151.2093 / 1e-7))
    (m,) = feed((build.n2k_id(129025, 0), data))
    assert m.kind == "position"
    assert m.values == {"lat": pytest.approx(-33.8688), "lon": pytest.approx(151.2093)}


def test_cog_sog_true_and_magnetic(feed, health, build):
    true = struct.pack("<BBHHH", 0, 0xFC, round(math.radians(90) / 1e-4), 515, 0xFFFF)
    magnetic = struct.pack("<BBHHH", 0, 0xFD, round(math.radians(90) / 1e-4), 515, 0xFFFF)
    a, b = feed((build.n2k_id(129026, 0), true), (build.n2k_id(129026, 0), magnetic))
    assert a.values == {"sog": pytest.approx(5.15), "cog": pytest.approx(math.pi / 2, abs=1e-4)}
    assert b.values == {"sog": pytest.approx(5.15)}  # magnetic COG and no variation known
    assert health.counters["unavailable.129026.cog_true"] == 1


def test_gnss_position_data_with_fix_and_time(feed, build):
    frames = build.fast_frames(build.pgn_129029(60.123456789, -23.5, method=4, sats=12, hdop=0.7), seq=1)
    ms = feed(*[(build.n2k_id(129029, 21, prio=3), f) for f in frames])
    (m,) = ms
    assert m.kind == "position"
    assert m.values == {
        "lat": pytest.approx(60.123456789, abs=1e-9),
        "lon": pytest.approx(-23.5),
        "fix_quality": 4,
        "sats": 12,
        "hdop": pytest.approx(0.7),
    }
    assert m.t_src == pytest.approx(20000 * 86400 + 3600.0)


def test_gnss_position_without_fix_is_rejected(feed, health, build):
    frames = build.fast_frames(build.pgn_129029(60.0, 20.0, method=0), seq=1)
    assert feed(*[(build.n2k_id(129029, 21), f) for f in frames]) == []
    assert health.counters["rejected.no_fix"] == 1


def test_impossible_values_are_rejected(feed, health, build):
    data = struct.pack("<ii", round(95.0 / 1e-7), 0)  # latitude beyond 90 degrees
    assert feed((build.n2k_id(129025, 0), data)) == []
    assert health.counters["rejected.invalid_value"] == 1
    assert "lat" in health.last_error


def test_system_time_reports_the_device_clock_offset(feed, health, build):
    data = struct.pack("<BBHI", 0, 0xF0, 20000, round(3600.5 / 1e-4))
    assert feed(build.raw(build.n2k_id(126992, 20), data, t=20000 * 86400 + 3600.0)) == []
    assert health.counters["pgn.126992"] == 1
    assert health.info["clock_offset_s"]["can0.20"] == pytest.approx(0.5)


def test_unknown_pgns_are_counted_once_per_message(feed, health, build):
    assert feed((build.n2k_id(130306, 9), bytes(8))) == []  # single-frame
    for f in build.fast_frames(bytes(30), seq=1):  # 126996 product info: fast-packet
        feed((build.n2k_id(126996, 9), f))
    feed((build.n2k_id(65280, 9), bytes(8)))  # proprietary, unknown to canboat
    assert health.counters["unknown_pgn.130306"] == 1
    assert health.counters["unknown_pgn.126996"] == 1
    assert health.counters["unknown_pgn.65280"] == 1


def test_counters_of_the_replay_summary(feed, health, build):
    feed((build.n2k_id(127250, 28), build.pgn_127250(1.0)), (0x320, bytes(6)))
    c = health.counters
    assert (c["frames"], c["frames.n2k"], c["frames.dbc"]) == (2, 1, 1)
    assert (c["pgn.127250"], c["measurements.heading"], c["measurements.accel_body"]) == (1, 1, 1)


def test_configured_address_name(make_decoder, build):
    dec = make_decoder(source_names={28: "gyro"})
    (m,) = dec.decode(build.raw(build.n2k_id(127250, 28), build.pgn_127250(1.0)))
    assert m.source == "gyro"


def _claim(name: int) -> bytes:
    return name.to_bytes(8, "little")


def test_iso_name_follows_the_device_across_an_address_change(make_decoder, build):
    gyro, gps = 0xC0788C00E7E04312, 0xA0A01CBEA005FF01
    dec = make_decoder(iso_names={f"{gyro:#x}": "gyro", f"{gps:x}": "gps"}, source_names={30: "by_address"})

    def heading_source(addr: int) -> str:
        (m,) = dec.decode(build.raw(build.n2k_id(127250, addr), build.pgn_127250(1.0)))
        return m.source

    assert heading_source(28) == "can0.28"  # no claim seen yet
    dec.decode(build.raw(build.n2k_id(60928, 28, prio=6), _claim(gyro)))
    dec.decode(build.raw(build.n2k_id(60928, 29, prio=6), _claim(gps)))
    assert (heading_source(28), heading_source(29)) == ("gyro", "gps")
    # Power cycle: the devices swap addresses; the sources follow the devices.
    dec.decode(build.raw(build.n2k_id(60928, 29, prio=6), _claim(gyro)))
    dec.decode(build.raw(build.n2k_id(60928, 28, prio=6), _claim(gps)))
    assert (heading_source(28), heading_source(29)) == ("gps", "gyro")
    # An unknown NAME on a configured address: the address name applies.
    dec.decode(build.raw(build.n2k_id(60928, 30, prio=6), _claim(0x1234)))
    assert heading_source(30) == "by_address"


def test_a_short_address_claim_is_rejected(feed, health, build):
    feed((build.n2k_id(60928, 28, prio=6), bytes(4)))
    assert health.counters["rejected.short_address_claim"] == 1


def test_records_without_identifier_are_rejected(decoder, health):
    for meta in (None, {}, {"id": "x", "ext": True}, {"id": 1 << 29, "ext": True}, {"id": 0x800, "ext": False}):
        assert decoder.decode(RawRecord("can", "can0", 1.0, bytes(8), meta)) == []
    assert health.counters["rejected.no_identifier"] == 5
    assert "frames" not in health.counters


def test_undecodable_payload_is_rejected(feed, health, build, monkeypatch):
    monkeypatch.setattr(n2k_codec, "decode_fields", lambda *a: None)
    assert feed((build.n2k_id(127250, 28), build.pgn_127250(1.0))) == []
    assert health.counters["rejected.undecodable"] == 1
