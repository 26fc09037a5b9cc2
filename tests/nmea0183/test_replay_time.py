"""Time of replayed lines (DESIGN §3): TAG/epoch, time of day + date, midnight, no time."""

from __future__ import annotations

import io
from datetime import datetime, timezone

import pytest

from edged.plugin import ReplayOptions
from edged_nmea0183.logs import NMEA0183
from edged_nmea0183.timeofday import nearest_time, parse_tod


def utc(s: str) -> float:
    return datetime.fromisoformat(s).replace(tzinfo=timezone.utc).timestamp()


def replay(text: str, health, date: str | None = None):
    stream = io.BytesIO(text.encode())
    return list(NMEA0183.open(stream, "log", health, ReplayOptions(date=date)))


def gga(nmea, hhmmss: str) -> str:
    return nmea(f"GPGGA,{hhmmss},5230.0000,N,00430.0000,E,1,08,0.9,1.0,M,46.0,M,,")


def test_midnight_rollover_advances_one_second(nmea, health):
    recs = replay("\n".join([gga(nmea, "235959"), gga(nmea, "000000")]) + "\n", health, date="2024-03-01")
    assert [r.t for r in recs] == [utc("2024-03-01T23:59:59"), utc("2024-03-02T00:00:00")]


def test_small_step_back_is_not_a_new_day(nmea, health):
    # humminbird-M37.log: time goes back 13 s inside the file; that is not midnight
    recs = replay("\n".join([gga(nmea, "194124"), gga(nmea, "194111")]) + "\n", health, date="2006-09-16")
    assert recs[1].t - recs[0].t == -13.0


def test_date_from_rmc_then_zda_and_untimed_lines_take_latest_time(nmea, health):
    lines = [
        nmea("GPRMC,094737,A,5251.0093,N,00518.8170,E,5.6,230.5,200818,1.4,E,A"),
        nmea("SDHDG,231.6,,,1.3,E"),
        nmea("GPZDA,094738.50,21,08,2018,-01,00"),
        nmea("SDHDG,231.7,,,1.3,E"),
    ]
    recs = replay("\n".join(lines) + "\n", health)
    assert [r.t for r in recs] == [
        utc("2018-08-20T09:47:37"),
        utc("2018-08-20T09:47:37"),
        utc("2018-08-21T09:47:38.5"),
        utc("2018-08-21T09:47:38.5"),
    ]


def test_lines_before_any_time_are_counted_and_skipped(nmea, health):
    lines = [nmea("HEHDT,10.0,T"), nmea("HEHDT,11.0,T"), gga(nmea, "120000"), nmea("HEHDT,12.0,T")]
    recs = replay("\n".join(lines) + "\n", health, date="2024-01-01")
    assert len(recs) == 2
    c = health.counters
    assert c["rejected.no_time"] == 2
    assert c["lines"] == c["accepted"] + c["rejected.no_time"] == 4


def test_lines_before_the_first_date_wait_for_it(nmea, health):
    # bundg_zeus_9.log starts with a GGA a second before the first RMC gives the date
    lines = [
        gga(nmea, "235959"),
        nmea("HEHDT,10.0,T"),
        nmea("GPRMC,000000,A,5251.0093,N,00518.8170,E,5.6,230.5,010324,,,A"),
    ]
    recs = replay("\n".join(lines) + "\n", health)
    assert [r.t for r in recs] == [utc("2024-02-29T23:59:59")] * 2 + [utc("2024-03-01T00:00:00")]
    assert "assumed_date" not in health.counters


def test_log_without_a_date_is_placed_on_1970_and_says_so(nmea, health):
    recs = replay(gga(nmea, "010203") + "\n", health)
    assert recs[0].t == 3723.0
    assert health.counters["assumed_date"] == 1
    assert "--date" in health.last_error


def test_date_option_places_a_dateless_log(nmea, health):
    recs = replay(gga(nmea, "010203") + "\n", health, date="2024-05-06")
    assert recs[0].t == utc("2024-05-06T01:02:03")


def test_bad_date_option_is_reported_not_raised(nmea, health):
    recs = replay(gga(nmea, "010203") + "\n", health, date="06/05/2024")
    assert recs[0].t == 3723.0  # the option was ignored, the line kept
    assert health.counters["assumed_date"] == 1


def test_tag_block_and_epoch_logs_use_their_own_time(nmea, health):
    from functools import reduce
    from operator import xor

    tag = "s:gyro,c:1700000000"
    lines = [
        "\\%s*%02X\\%s" % (tag, reduce(xor, tag.encode(), 0), nmea("HEHDT,10.0,T")),
        "1700000001.5 " + nmea("HEHDT,11.0,T"),
        nmea("HEHDT,12.0,T"),  # no time of its own: the latest log time
    ]
    recs = replay("\r\n".join(lines) + "\r\n", health)
    assert [r.t for r in recs] == [1700000000.0, 1700000001.5, 1700000001.5]
    assert recs[0].meta == {"tag": tag + "*%02X" % reduce(xor, tag.encode(), 0)}
    assert recs[0].data == nmea("HEHDT,10.0,T").encode()
    assert recs[1].meta is None


def test_two_digit_zda_year_is_read_as_2000s(nmea, health):
    # gofree-merrimac.log: `$GPZDA,195938,16,04,14,-02,00`
    recs = replay(nmea("GPZDA,195938,16,04,14,-02,00") + "\n", health)
    assert recs[0].t == utc("2014-04-16T19:59:38")


@pytest.mark.parametrize("s, expect", [("000000", 0.0), ("235959.50", 86399.5), ("", None), ("246000", None), ("12ab00", None)])
def test_parse_tod(s, expect):
    assert parse_tod(s) == expect


def test_nearest_time_crosses_midnight_both_ways():
    t = utc("2024-03-02T00:00:01")
    assert nearest_time(t, 86399.0) == utc("2024-03-01T23:59:59")
    assert nearest_time(utc("2024-03-01T23:59:59"), 1.0) == utc("2024-03-02T00:00:01")
