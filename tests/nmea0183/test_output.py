"""The NMEA 0183 output (issue 35): what pynmea2, not our encoder, reads back equals
the estimates within each field's resolution; what must not go out as a number goes
out empty with status V; rates are judged on data time; bad configuration is refused."""

from __future__ import annotations

import math
import os

import pynmea2
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from bridge_rig import MARKS, T0, CaptureSink, Ctx, draft, manoeuvre, stw
from edged.units import KNOT
from edged_nmea0183.encode import MAX_SENTENCE, xdr_name
from edged_nmea0183.output import Nmea0183Output, Nmea0183OutputConfig


def make(**cfg) -> tuple[Nmea0183Output, CaptureSink, Ctx]:
    c = Ctx("nmea_out")
    out = Nmea0183Output(Nmea0183OutputConfig(type="nmea0183", **cfg), c.ctx)
    out.check()
    sink = out.sink = CaptureSink()
    return out, sink, c


def parsed(sink: CaptureSink) -> dict[str, list[pynmea2.NMEASentence]]:
    by: dict[str, list[pynmea2.NMEASentence]] = {}
    for chunk in sink.sent:
        for line in chunk.decode("ascii").splitlines():
            assert len(line) + 2 <= MAX_SENTENCE, line
            s = pynmea2.parse(line, check=True)
            by.setdefault(s.sentence_type, []).append(s)
    return by


def test_every_sentence_decodes_to_the_estimates_within_its_resolution() -> None:
    out, sink, _ = make()
    s, m, d = stw(), manoeuvre(), draft()
    out.write([m, s, d])
    got = parsed(sink)
    assert sorted(got) == ["HDT", "ROT", "VBW", "VDR", "VHW", "XDR"]
    assert all(x.talker == "ED" for xs in got.values() for x in xs)
    vhw = got["VHW"][-1]
    assert float(vhw.heading_true) == pytest.approx(math.degrees(m.values["heading"]), abs=0.05)
    assert float(vhw.water_speed_knots) * KNOT == pytest.approx(s.values["stw"], abs=0.005 * KNOT)
    assert float(vhw.water_speed_km) / 3.6 == pytest.approx(s.values["stw"], abs=0.005 / 3.6)
    vbw = got["VBW"][-1]
    assert float(vbw.lon_water_spd) * KNOT == pytest.approx(s.values["stw_long"], abs=0.005 * KNOT)
    assert float(vbw.trans_water_spd) * KNOT == pytest.approx(s.values["stw_trans"], abs=0.005 * KNOT)
    assert float(vbw.lon_grnd_spd) * KNOT == pytest.approx(m.values["u"], abs=0.005 * KNOT)
    assert float(vbw.trans_grnd_spd) * KNOT == pytest.approx(m.values["v"], abs=0.005 * KNOT)
    assert (vbw.data_validity_water_spd, vbw.data_validity_grnd_spd) == ("A", "A")
    vdr = got["VDR"][-1]
    assert float(vdr.deg_t) == pytest.approx(math.degrees(s.values["current_set"]), abs=0.05)
    assert float(vdr.current) * KNOT == pytest.approx(s.values["current"], abs=0.005 * KNOT)
    assert float(got["HDT"][-1].heading) == pytest.approx(math.degrees(m.values["heading"]), abs=0.05)
    rot = got["ROT"][-1]
    assert float(rot.rate_of_turn) == pytest.approx(math.degrees(m.values["r"]) * 60.0, abs=0.05)
    assert rot.status == "A"
    readings = {}
    for x in got["XDR"]:
        for i in range(0, len(x.data), 4):
            typ, value, unit, name = x.data[i:i + 4]
            assert (typ, unit) == ("D", "M")
            readings[name] = float(value)
    want = {xdr_name(k): v["mean"] for k, v in d.values["marks"].items()}
    want |= {"DRAFT_MEAN": d.values["mean_draft"], "TRIM": d.values["trim"], "LIST": d.values["list"]}
    assert readings.keys() == want.keys() and len(want) == len(MARKS) + 3
    for k, v in want.items():
        assert readings[k] == pytest.approx(v, abs=0.005), k


@pytest.mark.parametrize("flag", ["stale", "converging"])
def test_stale_or_converging_estimates_go_out_empty_with_status_v(flag: str) -> None:
    out, sink, _ = make()
    out.write([stw(**{flag: True}), manoeuvre(**{flag: True}), draft(**{flag: True})])
    got = parsed(sink)
    assert got["VHW"][-1].heading_true is None and got["VHW"][-1].water_speed_knots is None
    vbw = got["VBW"][-1]
    assert (vbw.lon_water_spd, vbw.lon_grnd_spd) == (None, None)
    assert (vbw.data_validity_water_spd, vbw.data_validity_grnd_spd) == ("V", "V")
    assert got["VDR"][-1].deg_t is None and got["VDR"][-1].current is None
    assert got["HDT"][-1].heading is None
    assert not got["ROT"][-1].rate_of_turn and got["ROT"][-1].status == "V"
    assert all(x.data[i] == "" for x in got["XDR"] for i in range(1, len(x.data), 4))


def test_null_field_and_a_mark_out_go_out_empty() -> None:
    out, sink, _ = make()
    marks = {m: {"mean": 7.0, "ok": m != "mid_port"} for m in MARKS}
    out.write([manoeuvre(), stw(stw_trans=None, current=float("nan")), draft(marks=marks)])
    got = parsed(sink)
    assert got["VBW"][-1].data_validity_water_spd == "V" and got["VBW"][-1].trans_water_spd is None
    assert got["VDR"][-1].current is None
    names = {x.data[i + 3]: x.data[i + 1] for x in got["XDR"] for i in range(0, len(x.data), 4)}
    assert names["DRAFT_MP"] == "" and names["DRAFT_MS"] == "7.00"


def test_an_estimator_that_stopped_is_not_sent_as_a_number() -> None:
    out, sink, _ = make(max_age=5.0)
    out.write([manoeuvre(T0), stw(T0)])
    sink.sent.clear()
    out.write([stw(T0 + 6.0)])  # the manoeuvring state silent for 6 s of data while stw goes on
    got = parsed(sink)
    assert got["VHW"][-1].heading_true is None and got["VHW"][-1].water_speed_knots is not None
    assert (got["VBW"][-1].data_validity_water_spd, got["VBW"][-1].data_validity_grnd_spd) == ("A", "V")
    sink.sent.clear()
    out.write([stw(T0 + 7.0), manoeuvre(T0 + 7.0)])  # back: numbers again
    assert parsed(sink)["HDT"][-1].heading is not None


def test_each_sentence_at_its_own_rate_of_data_time() -> None:
    out, sink, _ = make(rates={"VBW": 0, "HDT": 5})
    out.write([stw(T0 + k / 10) for k in range(20)] + [manoeuvre(T0 + k / 10) for k in range(20)])
    got = parsed(sink)
    assert "VBW" not in got
    assert len(got["HDT"]) == 10 and len(got["ROT"]) == 20 and len(got["VDR"]) == 2
    # the same estimates again, at any speed: the same sentences (replay equals live)
    again, sink2, _ = make(rates={"VBW": 0, "HDT": 5})
    again.write([stw(T0 + k / 10) for k in range(20)] + [manoeuvre(T0 + k / 10) for k in range(20)])
    assert sink2.sent == sink.sent


def test_talker_is_configurable_and_is_the_outputs_mark() -> None:
    out, sink, _ = make(talker="E1")
    out.write([manoeuvre()])
    assert sink.sent[0].startswith(b"$E1HDT,")
    assert Nmea0183Output.own_marks(out.config) == {"nmea0183.talker": frozenset({"E1"})}


def test_only_the_configured_estimates_are_routed_to_it() -> None:
    out, _, _ = make(stw="stw_paper", draft="")
    assert out.keys == frozenset({"est/stw_paper", "est/manoeuvre"})


def test_sent_counts_what_went_not_what_the_link_refused() -> None:
    out, sink, c = make()
    out.write([manoeuvre(T0)])
    assert c.health.counters["sent"] == 2  # HDT, ROT
    sink.send = lambda data: False  # type: ignore[method-assign]  # the link is down
    out.write([manoeuvre(T0 + 1.0)])
    assert c.health.counters["sent"] == 2


@pytest.mark.parametrize("cfg, words", [
    ({"talker": "ed"}, "two capital letters"),
    ({"talker": "EDX"}, "two capital letters"),
    ({"talker": "GP"}, "instrument's talker"),
    ({"talker": "HE"}, "instrument's talker"),
    ({"transport": "serial"}, "needs a device"),
    ({"port": -1}, "greater than or equal to 0"),
    ({"max_age": 0}, "greater than 0"),
    ({"rates": {"HDT": float("nan")}}, "finite number"),
    ({"worker": "process"}, "daemon's loop only"),
])
def test_bad_configuration_is_refused_with_a_clear_message(cfg: dict, words: str) -> None:
    with pytest.raises(ValidationError, match=words):
        Nmea0183OutputConfig(type="nmea0183", **cfg)


@pytest.mark.parametrize("rates, words", [({"MWV": 1.0}, "unknown message 'MWV'"), ({"HDT": -1.0}, "not a rate"),
                                          ({"HDT": 1e6}, "not a rate")])
def test_bad_rates_are_refused_by_check(rates: dict, words: str) -> None:
    c = Ctx()
    out = Nmea0183Output(Nmea0183OutputConfig(type="nmea0183", rates=rates), c.ctx)
    with pytest.raises(ValueError, match=words):
        out.check()


def test_records_of_other_kinds_and_names_are_ignored() -> None:
    out, sink, c = make()
    from edged.records import Estimate, Measurement

    out.write([Measurement("heading", "gyro", T0, {"heading": 1.0}), Estimate("other", "x", T0, {"stw": 3.0}, "stw")])
    assert sink.sent == [] and c.health.counters.get("sent", 0) == 0


async def test_rates_a_serial_line_cannot_carry_are_named_at_open() -> None:
    """The defaults need ~680 characters a second (HDT and ROT at 10 Hz); a 4800 Bd
    line carries 480: the operator is told, and a second of backlog at most waits."""
    c = Ctx()
    out = Nmea0183Output(Nmea0183OutputConfig(type="nmea0183", transport="serial", device="/dev/edged-none"), c.ctx)
    await out.open()
    try:
        assert "carries 480: lower `rates` or raise `baudrate`" in (c.health.last_error or "")
        assert out.sink.line_buffer == 480  # type: ignore[union-attr]
    finally:
        await out.close()
    fast = Nmea0183Output(Nmea0183OutputConfig(type="nmea0183", transport="serial", device="/dev/edged-none",
                                               baudrate=38400), Ctx().ctx)
    assert fast.serial_overload() is None
    slowed = Nmea0183Output(Nmea0183OutputConfig(type="nmea0183", transport="serial", device="/dev/edged-none",
                                                 rates={"HDT": 2, "ROT": 1}), Ctx().ctx)
    assert slowed.serial_overload() is None  # about 360 characters a second: it fits


_ANY = st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**30, 10**30),
                 st.booleans(), st.text(max_size=3))


@settings(max_examples=int(os.environ.get("EDGED_FUZZ_EXAMPLES", "200")), deadline=None, derandomize=True)
@given(s=st.fixed_dictionaries({k: _ANY for k in ("stw", "stw_long", "stw_trans", "current", "current_set")}),
       m=st.fixed_dictionaries({k: _ANY for k in ("heading", "r", "u", "v")}),
       d=st.fixed_dictionaries({k: _ANY for k in ("mean_draft", "trim", "list")}), mark=_ANY)
def test_any_value_an_estimate_may_hold_gives_sentences_that_parse_and_fit(s, m, d, mark) -> None:
    """A filter that diverged (1e30 m/s), NaN, infinity, a string: every sentence still
    parses with its checksum, within 82 characters; what no field carries is empty, V."""
    out, sink, _ = make()
    marks = {k: {"mean": mark, "ok": True} for k in MARKS}
    out.write([manoeuvre(**m), stw(**s), draft(marks=marks, **d)])
    got = parsed(sink)  # (asserts the length of every line and its checksum)
    assert sorted(got) == ["HDT", "ROT", "VBW", "VDR", "VHW", "XDR"]
    vbw = got["VBW"][-1]
    assert (vbw.data_validity_water_spd == "A") == (vbw.lon_water_spd not in (None, "")
                                                    and vbw.trans_water_spd not in (None, ""))


async def test_an_output_whose_link_is_down_is_not_ok() -> None:
    """A serial port that is not there: the output runs, its messages are counted
    unsent, and health says it is not ok (an instrument gets nothing); with its link
    up, the same output is ok."""
    c = Ctx()
    out = Nmea0183Output(Nmea0183OutputConfig(type="nmea0183", transport="serial", device="/dev/edged-none"), c.ctx)
    c.health.set_state("running")
    await out.open()
    try:
        out.write([manoeuvre()])
        out.status()
        snap = c.health.snapshot()
        assert not snap["ok"] and snap["problems"][0].startswith("not delivering: the link is")
        assert snap["counters"]["unsent.link_down"] == 2 and "sent" not in snap["counters"]
    finally:
        await out.close()
    up = Ctx()
    linked = Nmea0183Output(Nmea0183OutputConfig(type="nmea0183"), up.ctx)
    linked.sink = CaptureSink()
    up.health.set_state("running")
    linked.status()
    assert up.health.snapshot()["ok"]
