"""A recording read back with the official `mcap` reader holds what went in (DESIGN §7)."""

from __future__ import annotations

import json
import math
from collections import Counter

import numpy as np
from mcap.reader import make_reader

import edged
from edged.records import KINDS, Estimate, Measurement, RawRecord


def _record(make_rig, tmp_path, recs, **cfg):
    rig = make_rig(path=str(tmp_path / "out.mcap"), **cfg)
    rig.open()
    rig.clock.step(0.5)
    rig.rec.write(recs)
    rig.rec.flush()
    rig.close()
    return rig, tmp_path / "out.mcap"


def test_channels_schemas_and_counts_with_the_official_reader(make_rig, tmp_path, records, schema_checks):
    check_schema, conforms = schema_checks
    rig, path = _record(make_rig, tmp_path, records)
    per_second = {
        "/raw/nmea0183/gnss1": 10,
        "/meas/position/gnss1": 10,
        "/location/gnss1": 10,
        "/meas/velocity_ground/gnss1": 10,
        "/raw/can/can0": 60,
        "/meas/draft/can0.DraftMark": 60,
        "/est/stw": 10,
        "/est/manoeuvre": 10,
        "/location/est/manoeuvre": 10,  # the estimate's position, for the map
        "/est/draft": 10,
        "/health": 1,
    }
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        counts = {summary.channels[c].topic: n for c, n in summary.statistics.channel_message_counts.items()}
        assert counts == {k: 3 * v for k, v in per_second.items()}
        for ch in summary.channels.values():
            assert ch.message_encoding == "json"
            schema = summary.schemas[ch.schema_id]
            assert schema.encoding == "jsonschema"
            check_schema(json.loads(schema.data))
        seen = Counter()
        for schema, ch, msg in reader.iter_messages(log_time_order=False):
            payload = json.loads(msg.data)
            conforms(payload, json.loads(schema.data))
            seen[ch.topic] += 1
        assert seen == Counter(counts)
    assert rig.health.counters["recorded"] == sum(counts.values())


def test_measurement_schemas_follow_the_kinds_table(make_rig, tmp_path, schema_checks):
    check_schema, conforms = schema_checks
    recs = [Measurement("depth", "echo", 1.0e9, {"depth": 12.5, "offset": -1.0})]
    _, path = _record(make_rig, tmp_path, recs)
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    (schema,) = [s for s in summary.schemas.values() if s.name == "edged.meas.depth"]
    body = json.loads(schema.data)
    assert set(body["properties"]) == {"t", "t_src", "source", *KINDS["depth"].field_names}
    assert set(body["required"]) == {"t", "source", "depth"}
    assert body["properties"]["depth"]["minimum"] == 0.0


def test_log_time_is_data_time_and_publish_time_the_clock(make_rig, tmp_path):
    recs = [RawRecord("nmea0183", "g", 1_700_000_000.123456789, b"$X*00", None)]
    rig, path = _record(make_rig, tmp_path, recs)
    with open(path, "rb") as f:
        (_, _, msg), = make_reader(f).iter_messages()
    assert msg.log_time == 1_700_000_000_123_456_717  # the float nearest ...789 (…716.54 ns), rounded
    assert msg.publish_time == round((rig.clock.now()) * 1e9)  # clock stepped 0.5 s past T0
    assert json.loads(msg.data)["t"] == 1_700_000_000.123456789


def test_positions_are_also_foxglove_location_fixes(make_rig, tmp_path):
    recs = [Measurement("position", "gnss1", 1_700_000_000.25, {"lat": 60.5, "lon": -3.25})]
    _, path = _record(make_rig, tmp_path, recs)
    with open(path, "rb") as f:
        msgs = {ch.topic: (s, json.loads(m.data)) for s, ch, m in make_reader(f).iter_messages()}
    schema, fix = msgs["/location/gnss1"]
    assert schema.name == "foxglove.LocationFix"
    assert fix["latitude"] == 60.5 and fix["longitude"] == -3.25
    assert fix["timestamp"] == {"sec": 1_700_000_000, "nsec": 250_000_000}
    assert len(fix["position_covariance"]) == 9 and fix["position_covariance_type"] == 0


def test_an_estimated_position_is_a_location_fix_with_its_sigma(make_rig, tmp_path):
    """The manoeuvring estimate on the map beside the GNSS: its lat/lon and its 1-σ
    north and east as the diagonal of the ENU covariance; a stale one is not drawn."""
    e = Estimate("manoeuvre", "manoeuvre", 1_700_000_000.5,
                 {"lat": 60.1, "lon": 23.5, "std": {"x": 2.0, "y": 3.0}, "stale": False}, "manoeuvre")
    old = Estimate("manoeuvre", "manoeuvre", 1_700_000_001.5,
                   {"lat": 60.1, "lon": 23.5, "std": {"x": 2.0, "y": 3.0}, "stale": True}, "manoeuvre")
    none = Estimate("stw", "stw", 1_700_000_000.5, {"stw": 3.0}, "stw")
    _, path = _record(make_rig, tmp_path, [e, old, none])
    with open(path, "rb") as f:
        msgs = [(s.name, ch.topic, json.loads(m.data)) for s, ch, m in make_reader(f).iter_messages()]
    fixes = [(name, d) for name, topic, d in msgs if topic == "/location/est/manoeuvre"]
    assert len(fixes) == 1 and fixes[0][0] == "foxglove.LocationFix"
    fix = fixes[0][1]
    assert (fix["latitude"], fix["longitude"], fix["frame_id"]) == (60.1, 23.5, "manoeuvre")
    assert fix["position_covariance"][0] == 9.0 and fix["position_covariance"][4] == 4.0  # east, north
    assert fix["position_covariance_type"] == 2
    assert not any(topic.startswith("/location/est/stw") for _, topic, _ in msgs)


def test_metadata_names_vessel_config_and_version(make_rig, tmp_path, records):
    _, path = _record(make_rig, tmp_path, records[:5])
    with open(path, "rb") as f:
        (meta,) = list(make_reader(f).iter_metadata())
    assert meta.name == "edged"
    assert meta.metadata["vessel_id"] == "ship1"
    assert meta.metadata["config"] == "[edged]\nvessel_id = 'ship1'\n"
    assert meta.metadata["edged_version"] == edged.__version__


def test_estimates_are_recorded_under_their_own_name_with_numpy_and_nan(make_rig, tmp_path):
    recs = [Estimate("fancy_new", "x", 5.0, {"a": np.float32(1.5), "v": np.arange(3), "bad": math.nan, "t": 99.0})]
    rig, path = _record(make_rig, tmp_path, recs)
    with open(path, "rb") as f:
        (_, ch, msg), = make_reader(f).iter_messages()
    assert ch.topic == "/est/fancy_new"
    assert json.loads(msg.data) == {"t": 5.0, "kind": None, "stale": False, "age": 0.0, "converging": False, "a": 1.5, "v": [0, 1, 2], "bad": None}
    assert rig.health.counters["nonfinite_as_null"] == 1


def test_unknown_records_bad_times_and_unencodable_values_are_counted(make_rig, tmp_path):
    good = RawRecord("nmea0183", "g", 2.0, b"$A*00", None)
    recs = [
        object(),
        RawRecord("nmea0183", "g", math.nan, b"$B*00", None),
        RawRecord("nmea0183", "g", -1.0, b"$B*00", None),  # before 1970: not an MCAP time
        RawRecord("nmea0183", "g", 2e10, b"$B*00", None),  # beyond uint64 nanoseconds
        RawRecord("can", "can0", 1.0, "not bytes", {"id": 1, "ext": False}),
        Estimate("stw", "stw", 1.0, {"x": object()}),
        good,
    ]
    rig, path = _record(make_rig, tmp_path, recs)
    c = rig.health.counters
    assert (c["rejected.unknown_record"], c["rejected.bad_time"], c["rejected.malformed"], c["rejected.unencodable"]) == (1, 3, 1, 1)
    assert rig.health.last_error is not None
    with open(path, "rb") as f:
        assert [json.loads(m.data)["line"] for _, _, m in make_reader(f).iter_messages()] == ["$A*00"]


def test_chunks_stay_small(make_rig, tmp_path, sample):
    _, path = _record(make_rig, tmp_path, sample(seconds=20), chunk_kib=8)
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert len(summary.chunk_indexes) > 3
    assert max(ci.uncompressed_size for ci in summary.chunk_indexes) < 8 * 1024 + 4096


def test_compression_options(make_rig, tmp_path, records):
    for comp in ("zstd", "lz4", "none"):
        rig = make_rig(path=str(tmp_path / f"{comp}.mcap"), compression=comp)
        rig.open()
        rig.rec.write(records)
        rig.close()
        with open(tmp_path / f"{comp}.mcap", "rb") as f:
            summary = make_reader(f).get_summary()
        assert {ci.compression for ci in summary.chunk_indexes} == {"" if comp == "none" else comp}
        assert summary.statistics.message_count == len(records) + 30 + 30  # + fixes and estimates' fixes
