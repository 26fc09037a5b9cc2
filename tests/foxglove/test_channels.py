"""What a browser receives is what the MCAP recording holds: topics, schemas, JSON
bytes and log times, for estimates and for the map's LocationFix."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from bridge_rig import T0, draft, manoeuvre, stw
from mcap.reader import make_reader
from mcap_rig import make_rig

from edged.records import HealthRecord, Measurement, RawRecord


async def _recorded(path: Path, records: list[Any]) -> dict[str, tuple[Any, Any, Any]]:
    """topic -> (schema, channel, message) of the last message on it, as the MCAP
    recorder wrote `records` into the file `path`."""
    rig = make_rig(path=str(path))
    await rig.rec.open()
    rig.rec.write(list(records))
    await rig.rec.close()
    out: dict[str, tuple[Any, Any, Any]] = {}
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            out[channel.topic] = (schema, channel, message)
    return out


def _same_channel(advert: dict[str, Any], schema: Any, channel: Any) -> None:
    assert advert["encoding"] == channel.message_encoding == "json"
    assert advert["schemaName"] == schema.name
    assert advert["schemaEncoding"] == schema.encoding == "jsonschema"
    assert advert["schema"].encode() == schema.data


async def test_est_stw_gets_the_bytes_the_mcap_holds(fox, client, tmp_path):
    out, c = await fox()
    fc = await client(out)
    out.write([stw(T0)])  # the channel appears with its first record
    await fc.subscribe(out, "/est/stw")
    e = stw(T0 + 1.25, stw=6.2345678901, current=None)
    out.write([e])
    topic, log_ns, payload = await fc.message()

    rec = await _recorded(tmp_path / "r.mcap", [e])
    schema, channel, message = rec["/est/stw"]
    assert topic == "/est/stw"
    assert payload == message.data  # byte for byte
    assert log_ns == message.log_time == (int(T0) + 1) * 10**9 + 250_000_000  # data time, to the ns
    _same_channel(fc.channels["/est/stw"], schema, channel)
    assert json.loads(payload)["stw"] == 6.2345678901
    assert c.health.counters["sent"] == 1 and c.health.counters["unwatched"] == 1


async def test_every_estimate_kind_and_health_as_recorded(fox, client, tmp_path):
    out, _ = await fox()
    fc = await client(out)
    recs = [manoeuvre(T0), draft(T0), HealthRecord(T0, {"outputs": {"fox": {"state": "running"}}})]
    out.write(recs)
    await fc.subscribe(out, "/est/manoeuvre", "/est/draft", "/health")
    later = [manoeuvre(T0 + 0.5), draft(T0 + 0.5), HealthRecord(T0 + 1, {"outputs": {"fox": {"state": "running"}}})]
    out.write(later)
    got = {topic: (ns, data) for topic, ns, data in [await fc.message() for _ in later]}
    rec = await _recorded(tmp_path / "r.mcap", later)
    for topic in ("/est/manoeuvre", "/est/draft", "/health"):
        schema, channel, message = rec[topic]
        assert got[topic] == (message.log_time, message.data), topic
        _same_channel(fc.channels[topic], schema, channel)


async def test_positions_are_location_fixes_as_in_the_recording(fox, client, tmp_path):
    out, _ = await fox()
    fc = await client(out)
    first = Measurement("position", "gnss1", T0, {"lat": 59.437, "lon": 24.745, "fix_quality": 1})
    out.write([first])
    await fc.subscribe(out, "/location/gnss1", "/meas/position/gnss1")
    m = Measurement("position", "gnss1", T0 + 1, {"lat": 59.4371234, "lon": 24.7451234, "hdop": 0.9})
    out.write([m])
    got = {topic: (ns, data) for topic, ns, data in [await fc.message(), await fc.message()]}

    rec = await _recorded(tmp_path / "r.mcap", [m])
    for topic in ("/location/gnss1", "/meas/position/gnss1"):
        schema, channel, message = rec[topic]
        assert got[topic] == (message.log_time, message.data), topic
        _same_channel(fc.channels[topic], schema, channel)
    assert fc.channels["/location/gnss1"]["schemaName"] == "foxglove.LocationFix"
    fix = json.loads(got["/location/gnss1"][1])
    assert (fix["latitude"], fix["longitude"]) == (59.4371234, 24.7451234)
    assert fix["timestamp"] == {"sec": int(T0 + 1), "nsec": 0}


async def test_channels_are_made_as_their_first_record_comes(fox, client):
    out, c = await fox()
    fc = await client(out)
    assert out.status()["channels"] == 0
    out.write([stw(T0)])
    await fc.channel("/est/stw")
    assert set(fc.channels) == {"/est/stw"}
    assert out.status()["channels"] == 1
    # nobody listens: not encoded, counted
    assert c.health.counters == {"unwatched": 1}


async def test_switches_choose_what_is_served(fox, client):
    out, _ = await fox(measurements=False, health=False)
    fc = await client(out)
    pos = Measurement("position", "gnss1", T0, {"lat": 59.4, "lon": 24.7})
    sog = Measurement("velocity_ground", "gnss1", T0, {"sog": 6.0})
    out.write([pos, sog, HealthRecord(T0, {}), stw(T0)])
    await fc.channel("/est/stw")  # the batch's last record: the others came before
    assert set(fc.channels) == {"/location/gnss1", "/est/stw"}
    assert out.status()["channels"] == 2


async def test_raw_records_are_never_served(fox, client):
    out, c = await fox()
    fc = await client(out)
    assert "raw" in out.exclude_keys  # not even routed to it
    out.write([RawRecord("nmea0183", "gnss1", T0, b"$GPGGA,,,,*00\r\n"), stw(T0)])
    await fc.channel("/est/stw")
    assert set(fc.channels) == {"/est/stw"}
    assert c.health.counters == {"unwatched": 1}
