"""Every shared real-world log replays through reader + decoder without an exception."""

from __future__ import annotations

from pathlib import Path

import pytest

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import Measurement, validate_measurement
from edged_nmea0183.logs import NMEA0183
from edged_nmea0183.plugin import Nmea0183Input

LOGS = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "nmea0183"


def replay_file(path: Path, date: str | None = None) -> tuple[ComponentHealth, list[Measurement], list]:
    health = ComponentHealth(path.stem, "input", "nmea0183", ManualClock())
    dec = Nmea0183Input.make_decoder(path.stem, None, health)
    raws, ms = [], []
    with path.open("rb") as f:
        assert NMEA0183.sniff(f.read(4096))
        f.seek(0)
        for raw in NMEA0183.open(f, path.stem, health, ReplayOptions(date=date, path=path)):
            raws.append(raw)
            ms += dec.decode(raw)
    return health, ms, raws


def _logs() -> list[Path]:
    return sorted(LOGS.glob("*.log")) if LOGS.is_dir() else []


@pytest.mark.parametrize("path", _logs(), ids=lambda p: p.name)
def test_log_replays_and_counters_add_up(path: Path):
    health, ms, raws = replay_file(path)
    c = health.counters
    rejected = sum(v for k, v in c.items() if k.startswith("rejected."))
    assert c["lines"] == c.get("accepted", 0) + rejected
    assert len(raws) == c.get("accepted", 0)
    decoded = sum(v for k, v in c.items() if k.split(".")[0] in ("sentences", "unknown", "encapsulated", "malformed"))
    assert decoded == len(raws)  # every record is accounted for by the decoder
    for m in ms:
        validate_measurement(m.kind, m.values)
    assert sum(v for k, v in c.items() if k.startswith("measurements.")) == len(ms)
    assert "decode_errors" not in c


def _need(name: str) -> Path:
    p = LOGS / name
    if not p.is_file():
        pytest.skip(f"../shared data not here: {p} not found")
    return p


def test_saab_gyro_heading_and_rate_of_turn():
    health, ms, _ = replay_file(_need("gpsd__test__daemon__saab-r4.log"))
    kinds = {m.kind for m in ms}
    assert {"heading", "yaw_rate", "position", "velocity_ground"} <= kinds
    assert health.counters["encapsulated.VDO"] == 11  # AIS kept raw, not decoded
    t = [m.t for m in ms]
    assert min(t) >= 1306933620 and max(t) <= 1306933650  # 2011-06-01 13:07 UTC


def test_skytraq_ths_and_json_lines():
    health, ms, _ = replay_file(_need("gpsd__test__daemon__skytraq-PX1172RH_DS.log"))
    assert health.counters["sentences.THS"] == 9
    assert health.counters["rejected.no_start"] == 3  # gpsd JSON lines
    assert any(m.kind == "position" and m.values.get("fix_quality") == 5 for m in ms)  # RTK


def test_hemi_without_fix_is_invalid_not_zero():
    health, ms, _ = replay_file(_need("gpsd__test__daemon__hemi.log"))
    assert health.counters["invalid.GGA"] > 150 and health.counters["invalid.HDT"] > 150
    assert all(m.values["lat"] != 0.0 for m in ms if m.kind == "position")


def test_plaka_empty_heading_sentences_and_assumed_date():
    health, ms, _ = replay_file(_need("signalk-server__samples__plaka.log"), date="2014-07-01")
    c = health.counters
    assert c["invalid.HDT"] == c["sentences.HDT"]  # all empty for 4 h
    assert "assumed_date" not in c
    water = [m for m in ms if m.kind == "water_speed"]
    assert len(water) == c["measurements.water_speed"] > 7000


def test_numeric_talkers_decode():
    # n2kd-183-merrimac.log has no time at all: each line is rejected as no_time by the
    # reader; decoded directly, its numeric talkers ($24HDG, $04HDM, $05DBT) work.
    from edged.records import RawRecord

    path = _need("signalk-server__samples__n2kd-183-merrimac.log")
    health = ComponentHealth("n2kd", "input", "nmea0183", ManualClock())
    dec = Nmea0183Input.make_decoder("n2kd", None, health)
    ms = []
    for line in path.read_bytes().splitlines():
        if line.startswith(b"$"):
            ms += dec.decode(RawRecord("nmea0183", "n2kd", 0.0, line))
    assert health.counters["sentences.HDG"] == 123 and health.counters["sentences.DBT"] == 11
    assert {m.kind for m in ms} >= {"depth"}
    assert health.counters["unknown.MWV"] == 147


def test_nmea2000_wrapped_in_0183_framing():
    """iKonvert `!PDGY` (no checksum) is the CAN input's; `$PCDIN`/`$MXPGN` sentences
    are checksummed NMEA 0183, read here and handed to the CAN decoder."""
    pdgy = b"".join(b"!PDGY,127250,2,3,255,481.%03d,2C20AAAAAAE=\r\n" % i for i in range(30))
    pcdin = b"".join(b"$PCDIN,01F119,00000000,0F,2AAF00D1067414FF*59\r\n" for _ in range(30))
    assert not NMEA0183.sniff(pdgy)
    assert NMEA0183.sniff(pcdin)
    body = b"HEHDT,123.4,T"
    hdt = b"$%s*%02X\r\n" % (body, __import__("functools").reduce(lambda a, b: a ^ b, body, 0))
    mixed = hdt * 30 + pdgy[:200]
    assert NMEA0183.sniff(mixed)


def test_shared_ikonvert_log_is_not_ours_but_replays(capsys):
    """Not claimed as NMEA 0183 (no `unknown.PDGY` counts): the CAN input reads it."""
    path = LOGS.parent / "n2k" / "canboat__samples__ikonvert.log"
    if not path.is_file():
        pytest.skip(f"../shared data not here: {path} not found")
    from edged.cli import main

    with path.open("rb") as f:
        assert not NMEA0183.sniff(f.read(4096))
    assert main(["replay", str(path), "--no-zenoh", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "pgn.127250" in out and "unknown.PDGY" not in out
