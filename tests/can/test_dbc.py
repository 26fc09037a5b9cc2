"""DBC frames of DESIGN §5: values at the extremes of each signal, flags, gaps, config."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from pydantic import ValidationError

from edged.config import ConfigError, parse_config
from edged.records import RawRecord
from edged.registry import Registry
from edged_can.config import CanConfig
from edged_can.plugin import CanInput
from edged_can.reference import MARKS, reference_dbc_path

REPO = Path(__file__).resolve().parents[2]


def draft_frame(raw_draft: int, status: int = 0, counter: int = 0) -> bytes:
    return struct.pack("<HBB", raw_draft, status, counter)


def test_deploy_copy_is_the_package_reference_dbc():
    assert (REPO / "deploy" / "edged-sensors.dbc").read_bytes() == reference_dbc_path().read_bytes()


def test_reference_dbc_matches_the_design_table():
    db = CanConfig(type="can").database
    layout = {
        m.frame_id: (m.name, m.length, [(s.name, s.start, s.length, s.is_signed, s.scale) for s in m.signals])
        for m in db.messages
    }
    draft = [("draft", 0, 16, False, 0.001), ("status", 16, 8, False, 1), ("counter", 24, 8, False, 1)]
    for i, mark in enumerate(MARKS):
        assert layout[0x310 + i] == (f"DraftMark_{mark}", 4, draft)
    assert layout[0x320] == ("ImuAccel", 6, [(a, 16 * i, 16, True, 0.001) for i, a in enumerate(("ax", "ay", "az"))])
    assert layout[0x321] == (
        "ImuRate", 8,
        [("yaw_rate", 0, 32, True, 1e-6), ("roll_rate", 32, 16, True, 1e-4), ("pitch_rate", 48, 16, True, 1e-4)],
    )
    assert layout[0x322] == (
        "ImuAttitude", 6,
        [("roll", 0, 16, True, 1e-4), ("pitch", 16, 16, True, 1e-4), ("heave", 32, 16, True, 0.001)],
    )
    assert all(not m.is_extended_frame and all(s.byte_order == "little_endian" for s in m.signals) for m in db.messages)


@pytest.mark.parametrize("i, mark", list(enumerate(MARKS)))
@pytest.mark.parametrize("raw, metres", [(0, 0.0), (12345, 12.345), (65534, 65.534)])
def test_draft_marks_at_the_extremes(feed, i, mark, raw, metres):
    (m,) = feed((0x310 + i, draft_frame(raw)))
    assert (m.kind, m.source) == ("draft", "can0.DraftMark")
    assert m.values == {"mark": mark, "draft": pytest.approx(metres), "status": 0}


def test_draft_unavailable_gives_no_measurement_and_is_counted(feed, health):
    assert feed((0x312, draft_frame(0xFFFF))) == []
    assert health.counters["unavailable.DraftMark_mid_port"] == 1


@pytest.mark.parametrize("status", [1, 2, 255])
def test_faulty_draft_is_passed_on_flagged(feed, status):
    (m,) = feed((0x315, draft_frame(8000, status)))
    assert m.values["status"] == status and m.values["draft"] == pytest.approx(8.0)


def test_draft_counter_gaps_are_lost_frames_and_wrap(feed, health):
    counters = [254, 255, 0, 3, 3, 4]  # 1 and 2 lost; 3 repeated
    ms = feed(*[(0x310, draft_frame(5000, 0, c)) for c in counters])
    assert len(ms) == len(counters)  # a repeated frame is still a reading
    assert health.counters["dbc.lost"] == 2
    assert health.counters["dbc.lost.DraftMark_fore_port"] == 2
    # each reading carries what its counter says was lost before it (issue 31): the
    # draft estimator counts a mark's gaps from it, not from delivery times
    assert [m.values.get("lost") for m in ms] == [None, 0, 0, 2, None, 0]
    assert health.counters["dbc.repeated"] == 1
    feed((0x311, draft_frame(5000, 0, 77)))  # each mark has its own counter
    assert health.counters["dbc.lost"] == 2


@pytest.mark.parametrize("raw, value", [(-32768, -32.768), (-1, -0.001), (0, 0.0), (32767, 32.767)])
def test_imu_accel_at_the_extremes(feed, raw, value):
    (m,) = feed((0x320, struct.pack("<hhh", raw, -raw if raw > -32768 else 0, 1000)))
    assert (m.kind, m.source) == ("accel_body", "can0.ImuAccel")
    assert m.values["ax"] == pytest.approx(value)
    assert m.values["az"] == pytest.approx(1.0)


@pytest.mark.parametrize("raw, r", [(-10_000_000, -10.0), (-1, -1e-6), (0, 0.0), (10_000_000, 10.0)])
def test_imu_yaw_rate_within_range(feed, raw, r):
    (m,) = feed((0x321, struct.pack("<ihh", raw, 32767, -32768)))
    assert (m.kind, m.source, m.values) == ("yaw_rate", "can0.ImuRate", {"r": pytest.approx(r)})


@pytest.mark.parametrize("raw", [-(2**31), 2**31 - 1])
def test_imu_yaw_rate_extremes_cannot_be_true_and_are_rejected(feed, health, raw):
    assert feed((0x321, struct.pack("<ihh", raw, 0, 0))) == []
    assert health.counters["rejected.invalid_value"] == 1
    assert "yaw_rate.r" in health.last_error


@pytest.mark.parametrize("raw, angle", [(-31415, -3.1415), (0, 0.0), (31415, 3.1415)])
def test_imu_attitude_within_range(feed, raw, angle):
    (m,) = feed((0x322, struct.pack("<hhh", raw, -raw, 32767)))
    assert m.kind == "attitude" and m.source == "can0.ImuAttitude"
    assert m.values == {"roll": pytest.approx(angle), "pitch": pytest.approx(-angle), "heave": pytest.approx(32.767)}


@pytest.mark.parametrize("raw", [-32768, 32767])
def test_imu_attitude_extremes_beyond_pi_are_rejected(feed, health, raw):
    assert feed((0x322, struct.pack("<hhh", raw, 0, 0))) == []
    assert health.counters["rejected.invalid_value"] == 1


def test_a_short_dbc_frame_is_rejected(feed, health):
    assert feed((0x320, bytes(3))) == []
    assert health.counters["rejected.dbc_frame"] == 1
    assert "ImuAccel" in health.last_error


def test_an_unknown_11_bit_frame_is_counted(feed, health):
    assert feed((0x123, bytes(8))) == []
    assert health.counters["unknown_id.0x123"] == 1


# ---- configuration -----------------------------------------------------------------

SITE_DBC = """VERSION ""
NS_ :
BS_:
BU_: S
BO_ 1280 HullDraft: 3 S
 SG_ level : 0|16@1+ (0.01,0) [0|600] "m" S
 SG_ flags : 16|8@1+ (1,0) [0|255] "" S
"""


def _errors(body: dict, tmp_path: Path) -> list[tuple[tuple, str]]:
    with pytest.raises(ValidationError) as exc:
        CanConfig.model_validate({"type": "can", **body}, context={"config_dir": tmp_path})
    return [(e["loc"], e["msg"]) for e in exc.value.errors()]


def test_bad_dbc_path_is_a_configuration_error_naming_it(tmp_path):
    (loc, msg), = _errors({"dbc": "missing.dbc"}, tmp_path)
    assert loc == ("dbc",) and "missing.dbc" in msg


def test_unreadable_dbc_is_a_configuration_error(tmp_path):
    (tmp_path / "bad.dbc").write_text("BO_ this is not a dbc\n")
    (loc, msg), = _errors({"dbc": "bad.dbc"}, tmp_path)
    assert loc == ("dbc",) and "cannot be read" in msg


def test_a_site_dbc_without_the_mapped_messages_names_the_mapping(tmp_path):
    (tmp_path / "site.dbc").write_text(SITE_DBC)
    (loc, msg), = _errors({"dbc": "site.dbc"}, tmp_path)  # reference mappings, site DBC
    assert loc == ("signals",) and "signals[0].message" in msg and "DraftMark_fore_port" in msg


def test_a_mapped_signal_missing_from_the_dbc_is_named(tmp_path):
    body = {"signals": [{"message": "ImuAccel", "kind": "accel_body", "fields": {"ax": "ax", "ay": "sway"}}]}
    (loc, msg), = _errors(body, tmp_path)
    assert loc == ("signals",) and "signals[0].fields.ay" in msg and "'sway'" in msg


@pytest.mark.parametrize(
    "mapping, key",
    [
        ({"message": "ImuAccel", "kind": "speed", "fields": {}}, "kind"),
        ({"message": "ImuAccel", "kind": "accel_body", "fields": {"ax": "ax", "bx": "ay"}}, "fields.bx"),
        ({"message": "ImuAccel", "kind": "accel_body", "fields": {"ax": "ax"}}, "fields"),
        ({"message": "ImuAccel", "kind": "accel_body", "fields": {"ax": "ax", "ay": "ay"}, "mark": "x"}, "mark"),
        ({"message": "ImuAccel", "kind": "accel_body", "fields": {"ax": "ax", "ay": "ay"}, "counter": "n"}, "counter"),
        ({"message": "ImuAccel", "kind": "accel_body", "fields": {"ax": "ax", "ay": "ay"}, "source": "{port}"}, "source"),
    ],
)
def test_inconsistent_mappings_are_named(tmp_path, mapping, key):
    errors = _errors({"signals": [mapping]}, tmp_path)
    assert any(key in ".".join(map(str, loc)) + " " + msg for loc, msg in errors), errors


@pytest.mark.parametrize(
    "body, loc",
    [
        ({"source_names": {254: "x"}}, ("source_names",)),
        ({"iso_names": {"not-hex": "x"}}, ("iso_names",)),
        ({"backoff_initial": 5, "backoff_max": 1}, ("backoff_max",)),
        ({"interface": "pcan"}, ("interface",)),
        ({"watchdog": 0}, ("watchdog",)),
        ({"colour": "red"}, ("colour",)),
    ],
)
def test_other_bad_keys_are_named(tmp_path, body, loc):
    assert [e[0] for e in _errors(body, tmp_path)] == [loc]


def test_a_site_dbc_with_its_own_mapping_decodes(tmp_path, health):
    (tmp_path / "site.dbc").write_text(SITE_DBC)
    cfg = CanConfig.model_validate(
        {
            "type": "can",
            "dbc": "site.dbc",
            "signals": [
                {"message": "HullDraft", "kind": "draft", "fields": {"draft": "level", "status": "flags"},
                 "mark": "bow", "source": "hull_{message}"}
            ],
        },
        context={"config_dir": tmp_path},
    )
    assert cfg.dbc == tmp_path / "site.dbc"
    dec = CanInput.make_decoder("can1", cfg, health)
    (m,) = dec.decode(RawRecord("can", "can1", 5.0, struct.pack("<HB", 1234, 0), {"id": 1280, "ext": False}))
    assert (m.kind, m.source, m.values) == ("draft", "hull_HullDraft", {"mark": "bow", "draft": pytest.approx(12.34), "status": 0})


def test_errors_through_the_core_configuration_name_the_input_key(tmp_path):
    registry = Registry(use_entry_points=False)
    registry.register("inputs", "can", CanInput)
    with pytest.raises(ConfigError) as exc:
        parse_config({"inputs": {"can0": {"type": "can", "dbc": "nope.dbc"}}}, registry, file="edged.toml",
                     config_dir=tmp_path)
    assert "edged.toml: inputs.can0.dbc:" in str(exc.value) and "nope.dbc" in str(exc.value)
