"""The Signal K output's deltas (issue 35): the specification's paths in SI units, the
estimate's data time as the timestamp, edged as the source, null (never a stale
number) for what must not go out, each message at its own rate of data time."""

from __future__ import annotations

import math
from datetime import datetime, timezone
from typing import Any

import orjson
import pytest

from bridge_rig import MARKS, T0, CaptureSink, Ctx, draft, manoeuvre, stw
from edged_signalk.output import SignalKOutput
from edged_signalk.config import SignalKOutputConfig


def make(name: str = "sk", **cfg: Any) -> tuple[SignalKOutput, CaptureSink, Ctx]:
    c = Ctx(name, "signalk")
    out = SignalKOutput(SignalKOutputConfig(type="signalk", **cfg), c.ctx)
    out.check()
    sink = CaptureSink()
    out.sink = sink  # type: ignore[assignment]
    return out, sink, c


def deltas(sink: CaptureSink) -> list[dict[str, Any]]:
    out = []
    for chunk in sink.sent:
        assert chunk.endswith(b"\r\n") and chunk.count(b"\n") == 1, chunk  # one delta a line
        out.append(orjson.loads(chunk))
    return out


def values(delta: dict[str, Any]) -> dict[str, Any]:
    (update,) = delta["updates"]
    return {v["path"]: v["value"] for v in update["values"]}


def by_first_path(sink: CaptureSink) -> dict[str, dict[str, Any]]:
    return {d["updates"][0]["values"][0]["path"]: d for d in deltas(sink)}


def test_stw_and_current_go_to_the_specifications_paths_in_si_units() -> None:
    out, sink, c = make()
    e = stw()
    out.write([e])
    got = by_first_path(sink)
    speed = values(got["navigation.speedThroughWater"])
    assert speed == {
        "navigation.speedThroughWater": e.values["stw"],
        "navigation.speedThroughWaterLongitudinal": e.values["stw_long"],
        "navigation.speedThroughWaterTransverse": e.values["stw_trans"],
    }
    assert values(got["environment.current"]) == {
        "environment.current": {"setTrue": e.values["current_set"], "drift": e.values["current"]}}
    assert c.health.counters["sent"] == 2


def test_heading_rate_of_turn_leeway_and_course_from_the_manoeuvring_state() -> None:
    out, sink, _ = make()
    e = manoeuvre()
    out.write([e])
    got = by_first_path(sink)
    assert values(got["navigation.headingTrue"]) == {
        "navigation.headingTrue": e.values["heading"],
        "navigation.rateOfTurn": e.values["r"],
        "navigation.leewayAngle": e.values["drift_angle_water"],
    }
    assert values(got["navigation.speedOverGround"]) == {
        "navigation.speedOverGround": e.values["sog"],
        "navigation.courseOverGroundTrue": e.values["cog"],
    }


def test_drafts_go_to_design_draft_depth_below_keel_and_edged_paths() -> None:
    out, sink, _ = make()
    e = draft()
    out.write([e])
    (d,) = deltas(sink)
    v = values(d)
    ev = e.values
    assert v["design.draft"] == {"current": ev["mean_draft"]}
    assert v["edged.draft.mean"] == ev["mean_draft"]
    for m in MARKS:
        assert v[f"edged.draft.marks.{m}"] == ev["marks"][m]["mean"]
    assert v["edged.draft.trim"] == ev["trim"]
    assert v["edged.draft.list"] == ev["list"]
    assert v["edged.draft.squat"] == ev["squat"]
    assert v["environment.depth.belowKeel"] == ev["ukc"]


def test_context_source_and_timestamp_of_the_estimates_data_time() -> None:
    out, sink, _ = make("bridge_sk")
    t = T0 + 0.1239
    out.write([stw(t)])
    d = deltas(sink)[0]
    assert d["context"] == "vessels.self"
    (update,) = d["updates"]
    assert update["$source"] == "edged.bridge_sk"
    expected = datetime.fromtimestamp(t, timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"
    assert update["timestamp"] == expected and expected.endswith(".123Z")


def test_a_configured_vessel_urn_is_the_context() -> None:
    urn = "vessels.urn:mrn:imo:mmsi:230123456"
    out, sink, _ = make(context=urn)
    out.write([manoeuvre()])
    assert {d["context"] for d in deltas(sink)} == {urn}


@pytest.mark.parametrize("flag", ["stale", "converging"])
def test_stale_or_converging_estimates_go_out_as_null(flag: str) -> None:
    out, sink, _ = make()
    out.write([stw(**{flag: True}), manoeuvre(**{flag: True}), draft(**{flag: True})])
    sent = deltas(sink)
    assert len(sent) == 5  # every message still goes out: the server learns the value is gone
    for d in sent:
        for path, v in values(d).items():
            if path == "design.draft":
                assert v == {"current": None}
            else:
                assert v is None, (path, v)


def test_one_null_member_and_a_mark_out() -> None:
    out, sink, _ = make()
    marks = {m: {"draft": 8.0, "mean": 8.01, "ok": m != "mid_port"} for m in MARKS}
    out.write([stw(current_set=None), draft(marks=marks)])
    got = by_first_path(sink)
    assert values(got["environment.current"])["environment.current"] == {"setTrue": None, "drift": 0.7717}
    v = values(got["design.draft"])
    assert v["edged.draft.marks.mid_port"] is None and v["edged.draft.marks.fore_port"] == 8.01


def test_an_estimator_that_stopped_is_not_sent_again() -> None:
    out, sink, _ = make(max_age=5.0)
    out.write([manoeuvre(T0), stw(T0)])
    sink.sent.clear()
    out.write([stw(T0 + k) for k in range(1, 10)])  # the manoeuvring state stopped
    paths = {d["updates"][0]["values"][0]["path"] for d in deltas(sink)}
    assert "navigation.speedThroughWater" in paths and "navigation.headingTrue" not in paths


def test_each_message_at_its_own_rate_of_data_time() -> None:
    out, sink, _ = make(rates={"course": 0, "heading": 2.0})
    out.write([manoeuvre(T0 + k * 0.1) for k in range(20)])  # 10 Hz for 2 s
    paths = [d["updates"][0]["values"][0]["path"] for d in deltas(sink)]
    assert paths.count("navigation.headingTrue") == 4  # 2 Hz
    assert "navigation.speedOverGround" not in paths  # switched off


def test_a_time_no_calendar_holds_is_counted_and_not_sent() -> None:
    out, sink, c = make()
    out.write([stw(1e20)])
    assert sink.sent == [] and c.health.counters["rejected.bad_time"] == 2
    assert c.health.counters.get("sent", 0) == 0


def test_a_mark_whose_name_is_no_path_segment_is_left_out_and_counted() -> None:
    out, sink, c = make()
    marks = {"fore.port": {"draft": 8.0, "mean": 8.0, "ok": True}, "aft_port": {"draft": 9.0, "mean": 9.0, "ok": True}}
    out.write([draft(marks=marks)])
    v = values(deltas(sink)[0])
    assert "edged.draft.marks.aft_port" in v and not any("fore" in p for p in v)
    assert c.health.counters["rejected.bad_mark"] == 1


def test_nan_or_infinite_values_go_out_as_null_never_as_invalid_json() -> None:
    out, sink, _ = make()
    out.write([stw(stw=math.nan, stw_long=math.inf)])
    v = values(by_first_path(sink)["navigation.speedThroughWater"])
    assert v["navigation.speedThroughWater"] is None and v["navigation.speedThroughWaterLongitudinal"] is None


def test_only_its_roles_estimates_are_routed_and_others_ignored() -> None:
    from edged.records import Measurement

    out, sink, c = make(stw="stw2", draft="")
    assert out.keys == frozenset({"est/stw2", "est/manoeuvre"})
    out.write([Measurement("heading", "gyro", T0, {"heading": 1.0}), stw(), draft()])
    assert sink.sent == [] and c.health.counters.get("sent", 0) == 0
