"""Every PGN the NMEA 2000 output sends, decoded by the `nmea2000` package's decoder
(its own fast-packet reassembly for 130577), equals the estimates it was made from
within the field's resolution; what must not go out as a number is "no data"."""

from __future__ import annotations

import math
from typing import Any

import pytest

from edged_can.output import wire
from edged_can.output.pgns import PGNS

from .conftest import T0, fields, man_est, split, stw_est

ANGLE, SPEED, ROT = 1e-4, 0.01, 3.125e-08
ALL = {128259, 130577, 127250, 127251, 128000, 129026}


def close(got: Any, want: float, res: float) -> bool:
    """Within half a step of the field's resolution (the encoder rounds)."""
    return got is not None and abs(float(got) - want) <= res / 2 + 1e-12


async def sent_after_both(rig: Any, stw: dict[str, Any] | None = None, man: dict[str, Any] | None = None
                          ) -> dict[int, Any]:
    """Write a manoeuvre estimate, then an STW estimate of the same data time (128259
    and 130577 go with the STW estimate); the last message of each PGN."""
    addr = await rig.claimed()
    rig.out.write([man_est(T0 + 10.0, **(man or {}))])
    rig.out.write([stw_est(T0 + 10.0, **(stw or {}))])
    got = await rig.peer.messages(ALL, src=addr)
    return {pgn: msgs[-1] for pgn, msgs in got.items()}


async def test_every_pgn_decodes_to_the_estimates(make_rig: Any) -> None:
    rig = await make_rig(stw_sensor_type="correlation")
    stw = {"stw": 4.127, "current": 0.374, "current_set": 2.50006}
    man = {"heading": 1.23456, "r": -0.0123456789, "sog": 4.316, "cog": 6.28, "drift_angle_water": -0.04567}
    m = await sent_after_both(rig, stw, man)

    f = fields(m[128259])
    assert close(f["speedWaterReferenced"], 4.127, SPEED) and close(f["speedGroundReferenced"], 4.316, SPEED)
    assert m[128259].fields[3].raw_value == 3  # Correlation (ultra sound)

    f = fields(m[130577])
    assert close(f["cog"], 6.28, ANGLE) and close(f["sog"], 4.316, SPEED)
    assert close(f["heading"], 1.23456, ANGLE) and close(f["speedThroughWater"], 4.127, SPEED)
    assert close(f["set"], 2.50006, ANGLE) and close(f["drift"], 0.374, SPEED)
    assert f["cogReference"] == "True"

    f = fields(m[127250])
    assert close(f["heading"], 1.23456, ANGLE) and f["reference"] == "True"
    assert f["deviation"] is None and f["variation"] is None
    assert close(fields(m[127251])["rate"], -0.0123456789, ROT)
    assert close(fields(m[128000])["leewayAngle"], -0.04567, ANGLE)
    f = fields(m[129026])
    assert close(f["cog"], 6.28, ANGLE) and close(f["sog"], 4.316, SPEED) and f["cogReference"] == "True"

    # One SID for the PGNs of one data time; priorities the standard's.
    assert len({fields(msg)["sid"] for msg in m.values()}) == 1
    for pgn, msg in m.items():
        assert msg.priority == PGNS[str(pgn)].prio


async def test_130577_is_a_fast_packet_of_several_frames(make_rig: Any) -> None:
    rig = await make_rig()
    addr = await rig.claimed()
    rig.out.write([man_est(T0 + 5.0), stw_est(T0 + 5.0)])
    await rig.peer.messages({130577}, src=addr)
    frames = [f for f in rig.peer.frames if split(f.arbitration_id)[1] == 130577]
    assert len(frames) == 3 and [f.data[0] & 0x1F for f in frames] == [0, 1, 2]
    assert frames[0].data[1] == 14  # the payload's length


@pytest.mark.parametrize("bad", [{"stale": True}, {"converging": True}])
async def test_stale_or_converging_estimates_go_out_as_no_data(make_rig: Any, bad: dict[str, Any]) -> None:
    rig = await make_rig()
    m = await sent_after_both(rig, stw=bad, man=bad)
    assert fields(m[128259])["speedWaterReferenced"] is None and fields(m[128259])["speedGroundReferenced"] is None
    f = fields(m[130577])
    assert all(f[k] is None for k in ("cog", "sog", "heading", "speedThroughWater", "set", "drift"))
    assert fields(m[127250])["heading"] is None and fields(m[127251])["rate"] is None
    assert fields(m[128000])["leewayAngle"] is None
    assert fields(m[129026])["cog"] is None and fields(m[129026])["sog"] is None


async def test_one_role_stale_the_other_still_sent(make_rig: Any) -> None:
    rig = await make_rig()
    m = await sent_after_both(rig, stw={"stale": True})
    f = fields(m[130577])
    assert f["speedThroughWater"] is None and f["set"] is None and f["drift"] is None
    assert close(f["heading"], 1.2345, ANGLE) and close(f["sog"], 4.31, SPEED)
    assert fields(m[128259])["speedWaterReferenced"] is None
    assert close(fields(m[128259])["speedGroundReferenced"], 4.31, SPEED)


async def test_values_outside_a_field_go_out_as_no_data(make_rig: Any) -> None:
    """A negative speed, an unsigned field's impossible value: no data, never a wrap."""
    rig = await make_rig()
    m = await sent_after_both(rig, stw={"stw": -0.2, "current": 700.0}, man={"heading": -0.5, "r": 80.0})
    assert fields(m[128259])["speedWaterReferenced"] is None
    assert fields(m[130577])["drift"] is None
    assert close(fields(m[127250])["heading"], 2 * math.pi - 0.5, ANGLE)  # −0.5 rad is 331.4°: wrapped into [0, 2π)
    assert fields(m[127251])["rate"] is None


def test_our_encoder_agrees_with_the_standard_layout_by_hand() -> None:
    """The package's encoder against the layouts written out (little-endian, LSBs):
    127250 heading 1.2345 rad true; 127251 −0.01 rad/s; 128259 STW 4.12 m/s."""
    assert wire.encode(127250, {"sid": 7, "heading": 1.2345, "reference": 0}) == bytes.fromhex("073930ff7fff7ffc")
    rot = (-320000).to_bytes(4, "little", signed=True)  # −0.01 / 3.125e-08
    assert wire.encode(127251, {"sid": 1, "rate": -0.01}) == b"\x01" + rot + b"\xff\xff\xff"
    assert wire.encode(128259, {"sid": 2, "speedWaterReferenced": 4.12}) == bytes.fromhex("029c01ffffffffff")
