"""NMEA 2000 fast-packet reassembly that says why a message was lost.

A fast-packet message (up to 223 bytes) travels as up to 32 frames. Byte 0 of every
frame holds a 3-bit sequence counter (same for all frames of one message) and a 5-bit
frame counter; frame 0 carries the total length in byte 1 and 6 data bytes, the
others 7. Messages are keyed by (source, PGN): one sender may interleave several
PGNs and several senders the same PGN.

Ours rather than the library's because edged must count each failure by reason:
- `fastpacket.lost`: a message that never completed (a frame never came); counted
  when the next message of that source and PGN begins;
- `fastpacket.out_of_order`: all frames came but not in order; the message is dropped
  because a reordered bus cannot be trusted to have kept the bytes together;
- `fastpacket.repeated`: a frame seen twice with the same bytes; the copy is ignored
  and the message goes on.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from edged.health import ComponentHealth

MAX_LENGTH = 223  # 6 + 31 * 7 bytes


@dataclass(slots=True)
class _Slot:
    """The message in progress (or just finished) for one (source, PGN)."""

    seq: int
    frames: dict[int, bytes] = field(default_factory=dict)
    last: int = -1  # highest frame counter seen
    disorder: bool = False
    done: bool = False

    def n_frames(self) -> int | None:
        first = self.frames.get(0)
        if first is None or len(first) < 2:
            return None
        length = first[1]
        return 1 if length <= 6 else 1 + (length - 6 + 6) // 7


class FastPacketAssembler:
    """Feeds frames in arrival order; returns a payload when a message completes."""

    def __init__(self, health: ComponentHealth) -> None:
        self._health = health
        self._slots: dict[tuple[int, int], _Slot] = {}

    def push(self, src: int, pgn: int, data: bytes) -> bytes | None:
        if not data:
            self._reject("fastpacket_empty", f"PGN {pgn} from {src}: empty fast-packet frame")
            return None
        seq, idx = data[0] >> 5, data[0] & 0x1F
        key = (src, pgn)
        slot = self._slots.get(key)
        if slot is not None and slot.seq == seq:
            seen = slot.frames.get(idx)
            if seen is not None:
                if seen == data:
                    self._health.count("fastpacket.repeated")
                    return None
                # Same counters, other bytes: a new message from a sender that does
                # not advance its sequence counter.
                slot = self._start(key, slot, seq)
            elif slot.done:
                slot = self._start(key, slot, seq)
        else:
            slot = self._start(key, slot, seq)
        if idx < slot.last:
            slot.disorder = True
        slot.last = max(slot.last, idx)
        slot.frames[idx] = data
        return self._complete(slot, src, pgn)

    def _start(self, key: tuple[int, int], old: _Slot | None, seq: int) -> _Slot:
        if old is not None and not old.done:
            self._health.count("fastpacket.lost")
        slot = _Slot(seq)
        self._slots[key] = slot
        return slot

    def _complete(self, slot: _Slot, src: int, pgn: int) -> bytes | None:
        n = slot.n_frames()
        if n is None:
            return None
        length = slot.frames[0][1]
        if length > MAX_LENGTH or slot.last >= n:
            slot.done = True
            self._reject("fastpacket_length", f"PGN {pgn} from {src}: fast-packet length {length} "
                         f"does not fit frame counter {slot.last}")
            return None
        if len(slot.frames) < n:
            return None
        slot.done = True
        if slot.disorder:
            self._health.count("fastpacket.out_of_order")
            return None
        frames = slot.frames
        payload = frames[0][2:8] + b"".join(frames[i][1:8] for i in range(1, n))
        if len(payload) < length:
            self._reject("fastpacket_short", f"PGN {pgn} from {src}: fast-packet frames shorter than length {length}")
            return None
        return payload[:length]

    def _reject(self, reason: str, message: str) -> None:
        self._health.count("rejected." + reason)
        self._health.error(message)
