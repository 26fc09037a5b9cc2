"""`edged fleet --record DIR` (issue 16): received JSON back to records, the routing of
samples to one MCAP file per vessel per UTC day, the refusals, and the command end to
end (a vessel's zenoh output, the fleet recording it, `edged inspect`/`export` of the
file). Every zenoh endpoint is on 127.0.0.1; processes are synchronised by their lines.
"""

from __future__ import annotations

import argparse
import asyncio
import io
import json
import logging
import math
import os
import signal
import subprocess
from pathlib import Path

import pytest

from edged.clock import ManualClock
from edged.jsonpayload import dumps, record_json
from edged.records import Estimate, HealthRecord
from edged_mcap.reading import ReadReport, iter_messages
from edged_zenoh.commands import fleet_main
from edged_zenoh.fleet import FleetTable
from edged_zenoh.fleetrecord import FleetRecorder, FleetRecordError, day_file
from edged_zenoh.fromjson import MAX_PAYLOAD, NotARecord, record_from_json, valid_name
from edged_zenoh.output import ZenohOutput, ZenohOutputConfig

from .conftest import PYTHON, REPO, SAFETY

T0 = 1_732_350_000.0  # 2024-11-23T08:20:00Z
MIDNIGHT = (T0 // 86_400 + 1) * 86_400  # 2024-11-24T00:00:00Z
DAY1, DAY2 = int(T0 // 86_400), int(T0 // 86_400) + 1


def _stw(t: float, stw: float, name: str = "stw") -> Estimate:
    return Estimate(name, name, t, {"stw": stw, "stw_std": 0.05, "dvl_stw": None, "stale": False, "age": 0.1,
                                    "converging": False, "mode": "tuned"}, "stw")


def _health(t: float) -> HealthRecord:
    return HealthRecord(t, {"t": t, "inputs": {"gnss1": {"state": "connected", "ok": True,
                                                         "counters": {"lines": 10}}}, "ok": True})


def _payload(rec) -> bytes:
    data, _ = dumps(record_json(rec))
    return data


def _read(path: Path) -> tuple[ReadReport, list[tuple[str, str, dict]]]:
    report = ReadReport()
    with open(path, "rb") as f:
        msgs = [(ch.topic, schema.name if schema else "", json.loads(m.data))
                for ch, schema, m in iter_messages(f, report)]
    return report, msgs


def _files(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file() or p.is_symlink())


@pytest.fixture
def recorder(tmp_path):
    made = []

    def make(**kw) -> FleetRecorder:
        kw.setdefault("clock", ManualClock(T0))
        kw.setdefault("recorder_options", {"fsync": False})
        r = FleetRecorder(kw.pop("directory", tmp_path / "rec"), **kw)
        r.open()
        made.append(r)
        return r

    yield make
    for r in made:
        r.close()


# -- received JSON back to records ------------------------------------------------------
def test_estimates_and_health_come_back_as_the_records_that_were_published():
    estimates = [
        _stw(T0, 5.5),
        Estimate("stw_paper", "stw_paper", T0 + 0.1, {"stw": 5.4, "stw_long": None}, "stw"),
        Estimate("manoeuvre", "manoeuvre", T0, {"heading": math.pi, "lat": 59.5, "lon": 10.25, "std": {"u": 0.1},
                                                 "predicted": [{"dt": 60.0, "lat": 59.51}], "stale": True,
                                                 "age": 6.0}, "manoeuvre"),
        Estimate("draft", "draft", T0, {"marks": {"fore_port": {"mean": 7.5, "ok": True}}, "mean_draft": 7.5}, "draft"),
        Estimate("mine", "mine", T0, {"x": 1}, None),  # a kind this version does not define
    ]
    for e in estimates:
        data = _payload(e)
        back = record_from_json(f"est/{e.name}", data)
        assert isinstance(back, Estimate)
        assert (back.name, back.source, back.t, back.kind) == (e.name, e.name, e.t, e.kind)
        assert _payload(back) == data  # the same bytes as on board: same channel payload
    h = _health(T0)
    back = record_from_json("health", _payload(h))
    assert isinstance(back, HealthRecord) and back.t == T0 and _payload(back) == _payload(h)


@pytest.mark.parametrize(
    "rest, payload, reason",
    [
        ("est/stw", b"\xff\xfe", "not_json"),
        ("est/stw", b'{"t": NaN, "stw": 1}', "not_json"),
        ("est/stw", b"[" * 100_000, "not_json"),
        ("est/stw", b'{"t": 1e999}', "not_json"),
        ("est/stw", b"[1, 2]", "not_object"),
        ("est/stw", b'{"stw": 1}', "bad_time"),
        ("est/stw", b'{"t": "1732350000"}', "bad_time"),
        ("est/stw", b'{"t": true}', "bad_time"),
        ("est/stw", b'{"t": 1e12}', "bad_time"),  # after 2100
        ("health", b'{"t": -5}', "bad_time"),
        ("est/stw", b'{"t": 1732350000, "kind": 3}', "bad_kind"),
        ("est/stw", b" " * (MAX_PAYLOAD + 1), "too_large"),
        ("est", b'{"t": 1732350000}', "bad_key"),
        ("est/a/b", b'{"t": 1732350000}', "bad_key"),
        ("est/..", b'{"t": 1732350000}', "bad_key"),
        ("meas/position/gnss1", b'{"t": 1732350000}', "bad_key"),
    ],
)
def test_what_is_no_record_is_refused_with_its_reason(rest, payload, reason):
    with pytest.raises(NotARecord) as exc:
        record_from_json(rest, payload)
    assert exc.value.reason == reason


def test_names_are_the_design_names_and_never_a_path():
    for good in ("aurora", "IMO9321483", "v_1.b-2", "_x", "a" * 128):
        assert valid_name(good), good
    for bad in ("", ".", "..", ".hidden", "-rf", "a/b", "a b", "ünï", "x\n", "a\\b", "a" * 129, "*", "a$b"):
        assert not valid_name(bad), bad


# -- routing: one file per vessel per UTC day ------------------------------------------
def test_two_vessels_and_a_day_boundary_make_three_readable_files(recorder, tmp_path):
    r = recorder()
    samples = [
        ("vessel/aurora/est/stw", _stw(MIDNIGHT - 2.0, 5.0)),
        ("vessel/borealis/est/stw", _stw(T0, 7.0)),
        ("vessel/aurora/health", _health(MIDNIGHT - 1.0)),
        ("vessel/aurora/est/stw", _stw(MIDNIGHT + 1.0, 5.25)),  # the next UTC day: a new file
        ("vessel/aurora/health", _health(MIDNIGHT - 0.5)),  # a straggler: the current file
        ("vessel/borealis/health", _health(T0 + 1.0)),
        ("vessel/aurora/est/stw", _stw(MIDNIGHT + 2.0, 5.5)),
    ]
    for key, rec in samples:
        r.take(key, _payload(rec))
    r.flush()
    r.close()
    rec = tmp_path / "rec"
    assert _files(tmp_path) == [
        "rec/aurora/aurora-2024-11-23.mcap",
        "rec/aurora/aurora-2024-11-24.mcap",
        "rec/borealis/borealis-2024-11-23.mcap",
    ]
    assert day_file(rec, "aurora", DAY2) == rec / "aurora" / "aurora-2024-11-24.mcap"
    by_file = {}
    for name in ("aurora/aurora-2024-11-23.mcap", "aurora/aurora-2024-11-24.mcap", "borealis/borealis-2024-11-23.mcap"):
        report, msgs = _read(rec / name)
        assert report.healthy, (name, report)
        by_file[name] = msgs
    # The channels of an on-board recording (DESIGN §7), with the very payloads published.
    assert by_file["aurora/aurora-2024-11-23.mcap"] == [
        ("/est/stw", "edged.est.stw", json.loads(_payload(_stw(MIDNIGHT - 2.0, 5.0)))),
        ("/health", "edged.health", json.loads(_payload(_health(MIDNIGHT - 1.0)))),
    ]
    day2 = by_file["aurora/aurora-2024-11-24.mcap"]
    assert [(t, s, m.get("stw")) for t, s, m in day2] == [
        ("/est/stw", "edged.est.stw", 5.25), ("/health", "edged.health", None), ("/est/stw", "edged.est.stw", 5.5)]
    assert [(t, m["t"]) for t, _, m in by_file["borealis/borealis-2024-11-23.mcap"]] == [
        ("/est/stw", T0), ("/health", T0 + 1.0)]
    c = r.counters()
    assert c["recorded"] == 7 and r.losses == 0 and r.files_made == 3
    assert r.health.counters["late_for_day"] == 1
    assert "7 messages of 2 vessel(s) in 3 file(s)" in r.summary()


def test_invalid_vessel_ids_are_refused_counted_logged_once_and_never_a_path(recorder, tmp_path, caplog):
    r = recorder()
    (tmp_path / "outside").mkdir()
    bad = ["..", ".", ".hidden", "-rf", "a b", "ünï", "x\n", "a\\..\\b", "a" * 129, ""]
    caplog.set_level(logging.WARNING, logger="edged.fleet.record")
    for vid in bad:
        for _ in range(3):
            r.take(f"vessel/{vid}/est/stw", _payload(_stw(T0, 5.0)))
    r.take("vessel/../../outside/est/stw", _payload(_stw(T0, 5.0)))  # vessel id `..`
    r.take("vessel/../outside/health", _payload(_health(T0)))
    r.flush()
    r.close()
    assert r.health.counters["refused.bad_vessel_id"] == 3 * len(bad) + 2
    assert r.files_made == 0 and r.counters().get("recorded", 0) == 0
    assert _files(tmp_path) == []  # nothing written anywhere, inside DIR or out of it
    assert sorted(p.name for p in tmp_path.iterdir()) == ["outside", "rec"]
    refusals = [rec for rec in caplog.records if "fleet-record-refused" in rec.getMessage()]
    assert len(refusals) == len(bad)  # each id once, however many samples
    assert all("\n" not in rec.getMessage() for rec in refusals)
    assert "refused bad_vessel_id 32" in r.summary()


def test_vessels_recorded_at_once_are_bounded(recorder, tmp_path, caplog):
    caplog.set_level(logging.WARNING, logger="edged.fleet.record")
    clock = ManualClock(T0)
    r = recorder(max_vessels=2, idle_finish=60.0, clock=clock)
    for vid in ("a", "b", "c", "c"):
        r.take(f"vessel/{vid}/est/stw", _payload(_stw(T0, 1.0)))
    assert r.health.counters["refused.too_many_vessels"] == 2
    (msg,) = [x.getMessage() for x in caplog.records if "too_many_vessels" in x.getMessage()]
    assert "the most at once (2)" in msg
    # A vessel silent for idle_finish has its file finished and frees its place.
    clock.step(30.0)
    r.take("vessel/a/est/stw", _payload(_stw(T0 + 30, 1.0)))
    clock.step(30.0)
    r.flush()  # b silent for 60 s: finished
    assert _read(tmp_path / "rec/b/b-2024-11-23.mcap")[0].healthy
    r.take("vessel/c/est/stw", _payload(_stw(T0 + 60, 1.0)))
    r.close()
    assert [m["t"] for _, _, m in _read(tmp_path / "rec/c/c-2024-11-23.mcap")[1]] == [T0 + 60]
    assert r.counters()["recorded"] == 4


def test_a_file_of_the_day_is_never_overwritten(recorder, tmp_path):
    first = recorder()
    first.take("vessel/aurora/est/stw", _payload(_stw(T0, 5.0)))
    first.close()
    second = recorder()  # `edged fleet` started again the same day
    second.take("vessel/aurora/est/stw", _payload(_stw(T0 + 10, 6.0)))
    # A vessel whose clock was set back by a day opens a file of that day of its own.
    second.take("vessel/aurora/est/stw", _payload(_stw(T0 - 86_400, 4.0)))
    second.close()
    rec = tmp_path / "rec/aurora"
    assert sorted(p.name for p in rec.iterdir()) == [
        "aurora-2024-11-22.mcap", "aurora-2024-11-23.mcap", "aurora-2024-11-23_2.mcap"]
    assert [m["stw"] for _, _, m in _read(rec / "aurora-2024-11-23.mcap")[1]] == [5.0]
    assert [m["stw"] for _, _, m in _read(rec / "aurora-2024-11-23_2.mcap")[1]] == [6.0]
    assert [m["stw"] for _, _, m in _read(rec / "aurora-2024-11-22.mcap")[1]] == [4.0]


def test_a_sample_taken_twice_is_written_once_and_flush_makes_it_durable(recorder, tmp_path):
    r = recorder()
    data = _payload(_stw(T0, 5.0))
    r.take("vessel/aurora/est/stw", data)  # the query's latest value at start ...
    r.take("vessel/aurora/est/stw", _payload(_stw(T0 - 0.5, 4.5)))  # ... a sample queued before it
    r.take("vessel/aurora/est/stw", data)  # ... and the same sample again, from the subscription
    r.take("vessel/aurora/est/stw", b"not json")
    assert r.health.counters["duplicates"] == 1 and r.health.counters["rejected.not_json"] == 1
    r.flush()
    # Before the file is finished, what was flushed is in it (a crash loses about a second).
    report, msgs = _read(tmp_path / "rec/aurora/aurora-2024-11-23.mcap")
    assert not report.finished and [m["stw"] for _, _, m in msgs] == [5.0, 4.5]


def test_the_open_file_limit_bounds_the_vessels_when_it_cannot_be_raised(tmp_path, monkeypatch, caplog):
    import resource

    def refuse(*_a):
        raise ValueError("not permitted")

    monkeypatch.setattr(resource, "getrlimit", lambda _r: (300, 300))
    monkeypatch.setattr(resource, "setrlimit", refuse)
    caplog.set_level(logging.WARNING, logger="edged.fleet.record")
    r = FleetRecorder(tmp_path / "rec", clock=ManualClock(T0))
    r.open()
    r.close()
    assert r.max_vessels == 300 - 256
    assert any("at most 44 vessels recorded at once" in x.getMessage() for x in caplog.records)


def test_a_recorder_configuration_that_cannot_be_is_refused_at_open(tmp_path):
    with pytest.raises(FleetRecordError, match="recorder configuration"):
        FleetRecorder(tmp_path / "rec", recorder_options={"chunk_kib": 0}).open()


def test_fleet_table_counts_a_payload_nested_too_deep():
    t = FleetTable()
    t.update("vessel/x/health", b"[" * 100_000, 1.0)
    assert t.bad_samples == 1


def test_record_dir_that_cannot_be_one_is_a_usage_error(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    assert fleet_main(argparse.Namespace(zenoh_config=None, record=str(f))) == 2
    assert "is not a directory" in capsys.readouterr().err


# -- end to end -------------------------------------------------------------------------
def _zenoh_config(tmp_path: Path, port: int) -> Path:
    zcfg = tmp_path / "fleet.json5"
    zcfg.write_text('{connect: {endpoints: ["tcp/127.0.0.1:%d"]}}' % port)
    return zcfg


def _edged(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([PYTHON, "-m", "edged.cli", *argv], capture_output=True, text=True, cwd=REPO,
                          timeout=120)


def _check_with_inspect_and_export(path: Path) -> list[dict]:
    ins = _edged("inspect", str(path))
    assert ins.returncode == 0, ins.stderr
    assert "finished" in ins.stdout and "UNFINISHED" not in ins.stdout
    assert "vessel    aurora" in ins.stdout
    lines = {ln.split()[0]: ln.split()[1] for ln in ins.stdout.splitlines() if ln.startswith("/")}
    assert lines["/est/stw"] == "edged.est.stw" and lines["/health"] == "edged.health"
    exp = _edged("export", str(path), "--topic", "/est/stw", "--format", "jsonl")
    assert exp.returncode == 0, exp.stderr
    return [json.loads(ln) for ln in exp.stdout.splitlines()]


def test_fleet_record_in_process_then_inspect_and_export(make_ctx, free_port, tmp_path):
    port = free_port()
    c = make_ctx("zenoh", "aurora")
    out = ZenohOutput(ZenohOutputConfig.model_validate({"type": "zenoh", "listen": [f"tcp/127.0.0.1:{port}"]}), c.ctx)
    zcfg = _zenoh_config(tmp_path, port)
    rec_dir = tmp_path / "shore"

    async def scenario() -> int:
        await out.open()
        await asyncio.wait_for(out.connected.wait(), SAFETY)
        out.write([_stw(T0, 5.5), Estimate("manoeuvre", "m", T0, {"heading": 1.0}, "manoeuvre"), _health(T0)])
        args = argparse.Namespace(zenoh_config=str(zcfg), out=io.StringIO(), refreshes=1, interval=None,
                                  duration=None, record=str(rec_dir))
        try:
            return await asyncio.to_thread(fleet_main, args)
        finally:
            await out.close()

    assert asyncio.run(scenario()) == 0
    path = rec_dir / "aurora" / "aurora-2024-11-23.mcap"
    assert _files(rec_dir) == ["aurora/aurora-2024-11-23.mcap"]
    rows = _check_with_inspect_and_export(path)
    assert [(r["stw"], r["kind"], r["t"]) for r in rows] == [(5.5, "stw", T0)]


def test_fleet_record_command_follows_a_vessel_and_finishes_its_file_on_sigterm(make_ctx, free_port, tmp_path, spawn):
    port = free_port()
    c = make_ctx("zenoh", "aurora")
    out = ZenohOutput(ZenohOutputConfig.model_validate({"type": "zenoh", "listen": [f"tcp/127.0.0.1:{port}"]}), c.ctx)
    zcfg = _zenoh_config(tmp_path, port)
    rec_dir = tmp_path / "shore"

    def row_says(stw: str):
        return lambda ln: ln.startswith("aurora ") and ln.split()[3] == stw

    async def scenario() -> tuple[int, str]:
        await out.open()
        await asyncio.wait_for(out.connected.wait(), SAFETY)
        out.write([_stw(T0, 5.5), _health(T0)])
        proc = spawn(PYTHON, "-m", "edged.cli", "fleet", "--zenoh-config", str(zcfg), "--record", str(rec_dir))
        try:
            # The latest values, from the query at start: the subscription is declared by then.
            await asyncio.to_thread(proc.expect, row_says("5.50"))
            # Health first: one link delivers in order, so once the estimate is in the table
            # the snapshot is in the fleet's queue, and the last drain before the files are
            # finished takes it if the loop did not.
            out.write([_health(T0 + 1.0), _stw(T0 + 1.0, 6.25)])
            await asyncio.to_thread(proc.expect, row_says("6.25"))  # taken from the subscription
            proc.proc.send_signal(signal.SIGTERM)
            rc = await asyncio.to_thread(proc.proc.wait, SAFETY)
            return rc, proc.proc.stderr.read()
        finally:
            await out.close()

    rc, err = asyncio.run(scenario())
    assert rc == 0, err
    assert "recording into" in err and "at most 1000 vessels at once" in err
    assert "recorded 4 messages of 1 vessel(s) in 1 file(s)" in err
    rows = _check_with_inspect_and_export(rec_dir / "aurora" / "aurora-2024-11-23.mcap")
    assert [(r["t"], r["stw"]) for r in rows] == [(T0, 5.5), (T0 + 1.0, 6.25)]
    assert not [p for p in tmp_path.rglob("*.mcap") if not str(p).startswith(str(rec_dir))]
    assert os.listdir(rec_dir) == ["aurora"]
