"""Fast-packet reassembly: interleaving, loss, repetition, reordering, file boundaries."""

from __future__ import annotations

import heapq
import io

import pytest

from edged.plugin import ReplayOptions
from edged_can.fastpacket import FastPacketAssembler
from edged_can.logs import CANDUMP
from edged_can.plugin import CanInput

PGN = 129029


def _fp(health) -> FastPacketAssembler:
    return FastPacketAssembler(health)


def test_message_is_reassembled_from_its_frames(health, build):
    payload = bytes(range(43))
    fp = _fp(health)
    frames = build.fast_frames(payload, seq=3)
    assert len(frames) == 7
    results = [fp.push(7, PGN, f) for f in frames]
    assert results[:-1] == [None] * 6
    assert results[-1] == payload


def test_interleaved_sources_and_pgns_are_kept_apart(health, build):
    a, b, c = bytes(range(20)), bytes(range(100, 120)), bytes(range(200, 220))
    fa, fb, fc = build.fast_frames(a, 1), build.fast_frames(b, 1), build.fast_frames(c, 2)
    fp = _fp(health)
    done = []
    for i in range(3):  # frame i of each message in turn
        for src, pgn, frames in ((1, PGN, fa), (2, PGN, fb), (1, 126996, fc)):
            r = fp.push(src, pgn, frames[i])
            if r is not None:
                done.append((src, pgn, r))
    assert done == [(1, PGN, a), (2, PGN, b), (1, 126996, c)]
    assert not any(k.startswith("fastpacket.") for k in health.counters)


def test_a_lost_frame_discards_the_message_and_is_counted(health, build):
    fp = _fp(health)
    first, second = bytes(range(30)), bytes(range(50, 80))
    frames = build.fast_frames(first, seq=0)
    for i, f in enumerate(frames):
        if i != 2:
            assert fp.push(5, PGN, f) is None
    # The next message of that source and PGN shows the first will never complete.
    out = [fp.push(5, PGN, f) for f in build.fast_frames(second, seq=1)]
    assert out[-1] == second
    assert health.counters["fastpacket.lost"] == 1


def test_a_lost_first_frame_is_counted_once(health, build):
    fp = _fp(health)
    for f in build.fast_frames(bytes(range(30)), seq=4)[1:]:
        assert fp.push(5, PGN, f) is None
    assert fp.push(5, PGN, build.fast_frames(bytes(range(30)), seq=5)[0]) is None
    assert health.counters["fastpacket.lost"] == 1


def test_a_repeated_frame_is_counted_and_ignored(health, build):
    fp = _fp(health)
    payload = bytes(range(25))
    frames = build.fast_frames(payload, seq=2)
    out = []
    for f in [frames[0], frames[1], frames[1], frames[2], frames[3]]:
        out.append(fp.push(9, PGN, f))
    assert out[-1] == payload
    assert health.counters["fastpacket.repeated"] == 1
    assert "fastpacket.lost" not in health.counters


def test_an_out_of_order_frame_discards_the_message(health, build):
    fp = _fp(health)
    frames = build.fast_frames(bytes(range(25)), seq=2)
    out = [fp.push(9, PGN, f) for f in (frames[0], frames[2], frames[1], frames[3])]
    assert out == [None] * 4
    assert health.counters["fastpacket.out_of_order"] == 1
    assert "fastpacket.lost" not in health.counters


def test_a_length_the_frames_cannot_hold_is_rejected(health):
    fp = _fp(health)
    assert fp.push(9, PGN, bytes([0x00, 250, 1, 2, 3, 4, 5, 6])) is None
    assert health.counters["rejected.fastpacket_length"] == 1
    assert fp.push(9, PGN, b"") is None
    assert health.counters["rejected.fastpacket_empty"] == 1


def test_a_short_last_frame_is_rejected(health):
    fp = _fp(health)
    assert fp.push(9, PGN, bytes([0x00, 10, 1, 2, 3, 4, 5, 6])) is None
    assert fp.push(9, PGN, bytes([0x01, 7])) is None  # 2 of the 4 missing bytes
    assert health.counters["rejected.fastpacket_short"] == 1


def _candump(frames: list[tuple[float, int, bytes]]) -> io.BytesIO:
    text = "".join(f"({t:.6f}) can0 {i:08X}#{d.hex().upper()}\n" for t, i, d in frames)
    return io.BytesIO(text.encode())


def test_a_message_split_across_two_log_files_is_reassembled(health, build):
    """Two candump files of one bus, merged in time order as `edged replay` does."""
    can_id = build.n2k_id(PGN, 33, prio=3)
    frames = build.fast_frames(build.pgn_129029(60.5, 23.25), seq=6)
    t0 = 1732350000.0
    stamped = [(t0 + 0.001 * i, can_id, f) for i, f in enumerate(frames)]
    file_a, file_b = _candump(stamped[:3]), _candump(stamped[3:])
    opts = ReplayOptions()
    recs = heapq.merge(
        CANDUMP.open(file_a, "part1", health, opts),
        CANDUMP.open(file_b, "part2", health, opts),
        key=lambda r: r.t,
    )
    decoders = {}
    out = []
    for raw in recs:
        if raw.source not in decoders:
            decoders[raw.source] = CanInput.make_decoder(raw.source, None, health)
        out += decoders[raw.source].decode(raw)
    assert list(decoders) == ["can0"]  # both files feed the decoder of bus can0
    assert len(out) == 1
    m = out[0]
    assert (m.kind, m.source) == ("position", "can0.33")
    assert m.values["lat"] == pytest.approx(60.5) and m.values["lon"] == pytest.approx(23.25)
    assert m.t == pytest.approx(t0 + 0.006)
    assert "fastpacket.lost" not in health.counters
