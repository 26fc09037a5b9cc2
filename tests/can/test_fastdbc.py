"""The struct decoder of byte-aligned DBC frames gives what cantools gives, value for value."""

from __future__ import annotations

import math
import random

import cantools
import pytest

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.records import RawRecord
from edged_can.config import CanConfig
from edged_can.dbc import DbcDecoder
from edged_can.emit import Emitter
from edged_can.fastdbc import unpacker

OTHER_DBC = """VERSION ""
BS_:
BU_: A
BO_ 100 Packed: 8 A
 SG_ nibble : 0|4@1+ (1,0) [0|15] "" A
 SG_ rest : 4|12@1+ (1,0) [0|4095] "" A
BO_ 101 Motorola: 2 A
 SG_ big : 7|16@0+ (1,0) [0|65535] "" A
BO_ 102 Gappy: 8 A
 SG_ lo : 8|16@1- (0.5,-3) [-20000|20000] "" A
 SG_ f : 32|32@1- (1,0) [0|0] "" A
BO_ 103 Muxed: 2 A
 SG_ mux M : 0|8@1+ (1,0) [0|255] "" A
 SG_ a m1 : 8|8@1+ (1,0) [0|255] "" A
SIG_VALTYPE_ 102 f : 1;
VAL_ 102 lo 7 "seven" ;
"""


def same(a: dict, b: dict) -> bool:
    if list(a) != list(b):
        return False
    for k in a:
        x, y = a[k], b[k]
        if type(x) is not type(y):
            return False
        if isinstance(x, float) and math.isnan(x):
            if not math.isnan(y):
                return False
        elif x != y or (isinstance(x, float) and math.copysign(1.0, x) != math.copysign(1.0, y)):
            return False
    return True


def test_every_reference_frame_decodes_as_cantools_decodes_it():
    db = CanConfig(type="can").database
    rng = random.Random(7)
    for msg in db.messages:
        fast = unpacker(msg)
        assert fast is not None, msg.name  # the reference frames are all byte-aligned
        samples = [bytes(msg.length), b"\xff" * msg.length]
        samples += [bytes(rng.getrandbits(8) for _ in range(msg.length)) for _ in range(2000)]
        if msg.name.startswith("DraftMark"):  # the named values: unavailable, each status
            samples += [bytes([0xFF, 0xFF, s, 3]) for s in range(4)]
        for data in samples:
            assert same(fast(data), msg.decode(data, decode_choices=True)), (msg.name, data.hex())


def test_frames_struct_cannot_read_are_left_to_cantools_and_the_rest_agree():
    db = cantools.database.load_string(OTHER_DBC, "dbc")
    assert unpacker(db.get_message_by_name("Packed")) is None  # bit fields
    assert unpacker(db.get_message_by_name("Motorola")) is None  # big-endian
    assert unpacker(db.get_message_by_name("Muxed")) is None  # multiplexed
    # two signals sharing a byte: cantools refuses them unless loaded with strict=False
    loose = cantools.database.load_string(
        'VERSION ""\nBU_: A\nBO_ 104 Overlap: 4 A\n SG_ word : 0|16@1+ (1,0) [0|65535] "" A\n'
        ' SG_ high : 8|16@1+ (1,0) [0|65535] "" A\n', "dbc", strict=False)
    assert unpacker(loose.get_message_by_name("Overlap")) is None
    gappy = db.get_message_by_name("Gappy")
    fast = unpacker(gappy)
    assert fast is not None
    rng = random.Random(3)
    samples = [bytes([0, 7, 0, 0, 0, 0, 0xC0, 0x7F]), bytes([0, 0, 0, 0, 0, 0, 0, 0x80])]  # a choice; NaN; −0.0
    samples += [bytes(rng.getrandbits(8) for _ in range(8)) for _ in range(2000)]
    for data in samples:
        assert same(fast(data), gappy.decode(data, decode_choices=True)), data.hex()


def test_a_frame_of_another_length_still_goes_through_cantools():
    health = ComponentHealth("can0", "input", "can", ManualClock(0.0))
    dec = DbcDecoder("can0", CanConfig(type="can"), health, Emitter(health))
    short = dec.decode(RawRecord("can", "can0", 1.0, b"\x10\x27\x00", {"id": 0x310, "ext": False}), 0x310, False)
    assert short == [] and health.counters["rejected.dbc_frame"] == 1  # cantools: wrong data size
    long = dec.decode(RawRecord("can", "can0", 2.0, b"\x10\x27\x00\x01\xee", {"id": 0x310, "ext": False}), 0x310, False)
    assert [m.values["draft"] for m in long] == [pytest.approx(10.0)]  # cantools ignores the excess byte
