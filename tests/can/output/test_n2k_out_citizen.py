"""The NMEA 2000 output as a bus citizen on a python-can `virtual` bus: it claims an
address with its NAME, gives it up to a higher priority NAME and goes on sending
from a free one, defends it against a lower priority one, answers requests for its
claim, its product information and its PGN list, and beats."""

from __future__ import annotations

from typing import Any

import edged
from nmea2000._canboat import Reassembler
from edged_can.output.citizen import name_of
from edged_can.output.marks import name_hex
from edged_can.output.plugin import Nmea2000Output

from waiting import wait_for

from .conftest import T0, fields, man_est, split


def claim_of(msg: Any) -> int:
    return int.from_bytes(bytes(msg.data), "little")


def request(pgn: int) -> bytes:
    return pgn.to_bytes(3, "little")


async def test_claims_the_preferred_address_with_the_configured_name(make_rig: Any) -> None:
    rig = await make_rig(address=42, unique_number=1234, manufacturer_code=999, device_instance=3)
    await rig.out.link.connected.wait()
    await rig.peer.frame(59904)
    rig.clock.step(1.0)
    claim = await rig.peer.message(60928)
    f = {x.id: x.raw_value for x in claim.fields}
    assert claim.source == 42
    assert (f["uniqueNumber"], f["manufacturerCode"], f["deviceFunction"], f["deviceClass"], f["industryGroup"]) == (
        1234, 999, 170, 60, 4)
    assert f["deviceInstanceLower"] == 3 and f["arbitraryAddressCapable"] == 1
    rig.clock.step(0.3)
    await rig.peer.frame(126993, src=42)
    assert rig.health.info["address"] == 42 and rig.health.info["address_state"] == "claimed"
    assert Nmea2000Output.own_marks(rig.out.config) == {"n2k.name": frozenset({name_hex(rig.out.citizen.name)})}


async def test_nothing_but_claims_before_the_address_is_ours(make_rig: Any) -> None:
    rig = await make_rig()
    await rig.out.link.connected.wait()
    await rig.peer.frame(59904)
    rig.out.write([man_est(T0)])
    assert rig.health.counters["unsent.no_address"] == 4  # the PGNs that go with the manoeuvre
    rig.peer.send(6, 59904, 10, 255, request(60928))  # the claim is pending: no answer yet...
    rig.clock.step(1.0)
    await rig.peer.frame(60928)  # ...the claim is the next frame: no PGN went before it
    assert {split(f.arbitration_id)[1] for f in rig.peer.frames} == {59904, 60928}


async def test_a_higher_priority_name_takes_our_address_we_move_and_keep_sending(make_rig: Any) -> None:
    rig = await make_rig(address=35)
    addr = await rig.claimed()
    assert addr == 35
    ours = rig.out.citizen.name
    rig.peer.send(6, 60928, 35, 255, (ours - 1).to_bytes(8, "little"))  # numerically lower: wins
    claim = await rig.peer.frame(60928)
    new = split(claim.arbitration_id)[2]
    assert new not in (35, 254) and claim_of(claim) == ours
    rig.clock.step(0.3)
    await rig.peer.frame(126993, src=new)
    rig.out.write([man_est(T0 + 5.0)])
    got = await rig.peer.messages({127250}, src=new)
    assert fields(got[127250][-1])["heading"] is not None
    assert rig.health.counters["address_lost"] == 1 and rig.health.counters["address_claims"] == 2
    assert rig.health.info["address"] == new


async def test_a_claim_of_a_taken_address_is_not_taken_again(make_rig: Any) -> None:
    """During the scan a device claims 36; losing 35 then moves us past 36."""
    rig = await make_rig(address=35)
    await rig.out.link.connected.wait()
    await rig.peer.frame(59904)
    rig.peer.send(6, 60928, 36, 255, (5).to_bytes(8, "little"))
    rig.clock.step(1.0)
    await rig.peer.frame(60928, src=35)
    rig.clock.step(0.3)
    await rig.peer.frame(126993, src=35)
    rig.peer.send(6, 60928, 35, 255, (1).to_bytes(8, "little"))
    claim = await rig.peer.frame(60928)
    assert split(claim.arbitration_id)[2] not in (35, 36, 254)


async def test_a_lower_priority_name_is_answered_with_our_claim(make_rig: Any) -> None:
    rig = await make_rig(address=35)
    await rig.claimed()
    ours = rig.out.citizen.name
    rig.peer.send(6, 60928, 35, 255, (ours + 1).to_bytes(8, "little"))
    claim = await rig.peer.frame(60928)
    assert split(claim.arbitration_id)[2] == 35 and claim_of(claim) == ours
    rig.clock.step(0.3)
    rig.out.write([man_est(T0 + 5.0)])
    await rig.peer.messages({127250}, src=35)
    assert "address_lost" not in rig.health.counters


async def test_product_information_is_answered(make_rig: Any) -> None:
    rig = await make_rig(model_version="v2", serial="S-17")
    addr = await rig.claimed()
    rig.peer.send(6, 59904, 10, addr, request(126996))
    info = await rig.peer.message(126996, src=addr)
    f = fields(info)
    assert f["modelId"] == "edged" and f["softwareVersionCode"] == edged.__version__
    assert f["modelVersion"] == "v2" and f["modelSerialCode"] == "S-17"
    assert rig.health.counters["requests_answered"] == 1


async def test_a_request_to_everyone_for_our_claim_is_answered(make_rig: Any) -> None:
    rig = await make_rig()
    addr = await rig.claimed()
    rig.peer.send(6, 59904, 10, 255, request(60928))
    claim = await rig.peer.frame(60928, src=addr)
    assert claim_of(claim) == name_of(rig.out.config)
    assert rig.health.counters["requests_answered"] == 1


async def test_the_pgn_list_names_what_we_send(make_rig: Any) -> None:
    rig = await make_rig()
    addr = await rig.claimed()
    rig.peer.send(6, 59904, 10, addr, request(126464))
    lists: dict[int, set[int]] = {}
    join = Reassembler()
    while len(lists) < 2:  # the transmit list (function 0), then the receive list (1)
        frame = await rig.peer.frame(126464, src=addr)
        assert split(frame.arbitration_id)[3] == 10  # to the one who asked
        payload = join.push(126464, bytes(frame.data), addr, 10, 6)
        if payload is not None:
            lists[payload[0]] = {int.from_bytes(payload[i:i + 3], "little") for i in range(1, len(payload), 3)}
    assert {128259, 130577, 127250, 127251, 128000, 129026, 60928, 126996, 126993} <= lists[0]
    assert {59904, 60928} <= lists[1]


async def test_a_request_of_us_for_a_pgn_we_do_not_send_is_refused(make_rig: Any) -> None:
    rig = await make_rig()
    addr = await rig.claimed()
    rig.peer.send(6, 59904, 10, addr, request(129029))
    ack = await rig.peer.message(59392, src=addr)
    f = {x.id: x.raw_value for x in ack.fields}
    assert f["control"] == 1 and f["pgn"] == 129029  # NAK
    rig.peer.send(6, 59904, 10, 255, request(129029))  # to everyone: not ours to answer
    rig.peer.send(6, 59904, 10, addr, request(126996))
    await rig.peer.message(126996, src=addr)
    assert rig.health.counters["requests_answered"] == 2


async def test_heartbeat_every_interval_of_clock_time(make_rig: Any) -> None:
    rig = await make_rig(heartbeat=30.0)
    addr = await rig.claimed()
    rig.clock.step(29.0)
    rig.peer.send(6, 59904, 10, addr, request(126996))  # a frame to wait for: no beat before it
    await rig.peer.frame(126996, src=addr)
    assert [split(f.arbitration_id)[1] for f in rig.peer.frames].count(126993) == 1
    rig.clock.step(1.0)
    beat = await rig.peer.message(126993, src=addr)
    assert beat.priority == 7 and fields(beat)["dataTransmitOffset"] == 30.0
    assert fields(beat)["sequenceCounter"] == 1 and rig.health.counters["heartbeats"] == 2


async def test_a_flood_of_requests_gets_one_answer_a_second(make_rig: Any) -> None:
    """A node asking for product information in a loop would fill the bus with our
    fast-packets (20 frames each): it is answered once a second, the rest counted."""
    rig = await make_rig()
    addr = await rig.claimed()
    for _ in range(50):
        rig.peer.send(6, 59904, 10, addr, request(126996))
    await rig.peer.message(126996, src=addr)
    await wait_for(lambda: rig.health.counters.get("rejected.request_flood", 0) == 49)
    assert rig.health.counters["requests_answered"] == 1
    rig.clock.step(1.0)  # a second later it is answered again
    rig.peer.send(6, 59904, 10, addr, request(126996))
    await rig.peer.message(126996, src=addr)
    assert rig.health.counters["requests_answered"] == 2


async def test_health_is_not_ok_while_no_address_is_ours(make_rig: Any) -> None:
    """On the bus but still claiming (or with none free): nothing goes out, and health
    says so; once the address is held, the problem is gone."""
    rig = await make_rig()
    await rig.out.link.connected.wait()
    rig.out.status()
    assert rig.health.problems == ["not delivering: no address of its own on the bus (claiming, or none free)"]
    await rig.claimed()
    rig.out.status()
    assert rig.health.problems == []
