"""Actisense BST binary (NGT-1, NGX, PRO-NDC): `DLE STX <BST id> … <checksum> DLE ETX`.

What the gateway sends over its serial port (or a TCP relay of it), one BST message
between `DLE STX` (0x10 0x02) and `DLE ETX` (0x10 0x03), a 0x10 inside it doubled
(`DLE DLE`). The sum of every byte from the BST id to the checksum is 0 (mod 256).
The BST ids read here:
- 0x93, "N2K message received" (NGT-1): `93 len prio pgn(3, LE) dst src timer(4, LE)
  n data(n) ck`, len = 11 + n; a whole message (the NGT-1 reassembles fast-packets);
- 0xD0, BST-D0 (NGX, PRO-NDC in "N2K" mode): `D0 len(2, LE) dst src PS PF DP/prio
  control timer(4, LE) data ck`, len = 13 + n (the id to the data); a whole message;
- 0x95, BST-95 (the same in "raw CAN" mode): `95 len timer(2) src PS PF DP/prio
  data(≤ 8) ck`, len = 6 + n; one CAN frame, reassembled by our fast-packet assembler;
- 0xA0 / 0xA1 / 0x94: the gateway's answers to commands, commands, and messages sent
  by the PC: counted `gateway_messages` / `gateway_tx`, not measurements.
Times: the gateway's timers are relative and wrap; a live record is stamped by the
input's clock, as a bus frame is.

A raw record holds one message's bytes as they came, framing and stuffing included,
so a recording replays through `frame` exactly as the gateway's stream was read.
`Deframer` cuts a stream into such messages and counts what is not one.

From the `nmea2000` package: the start-up command bytes (`GatewayCodec("ngt1").open()`,
used by the live input) and, in the tests, its BST-D0/95 encoders as an independent
writer of the format. Ours: its `bdtp_unwrap` drops noise, bad escapes and cut
messages silently and its decoders return its own message objects; our decoder needs
(prio, PGN, src, dst, data) and a count per reason.
"""

from __future__ import annotations

from typing import Any

from . import Bad, Frame, Message, can_id

NAME = "actisense_bst"
DLE, STX, ETX = 0x10, 0x02, 0x03
_START = bytes((DLE, STX))
#: Longest BST message accepted (a 223-byte payload, its header and every byte stuffed).
MAX_FRAME = 2 * (223 + 16) + 4
_GATEWAY_RX = (0xA0, 0xF0, 0xF1, 0xF2)  # command answers, status and startup reports
_GATEWAY_TX = (0xA1, 0x94)  # commands to the gateway, N2K messages the PC sends


class Deframer:
    """Bytes of a BST stream -> whole messages (their wire bytes).

    Counters (in `health`): `discarded_bytes` (noise between messages: line noise, the
    middle of a message the port opened into), `rejected.bad_escape` (DLE followed by
    neither DLE, ETX nor STX), `rejected.too_long` (no end within MAX_FRAME bytes),
    `partial_messages` (a message cut by a new start, or by the end of the connection:
    `end`). The same bytes fed in any split give the same messages.
    """

    __slots__ = ("buf", "health")

    def __init__(self, health: Any) -> None:
        self.buf = bytearray()
        self.health = health

    def feed(self, data: bytes) -> list[bytes]:
        buf = self.buf
        buf += data
        out: list[bytes] = []
        h = self.health
        while True:
            start = buf.find(_START)
            if start < 0:
                keep = 1 if buf.endswith(b"\x10") else 0  # maybe half of a start
                if len(buf) > keep:
                    h.count("discarded_bytes", len(buf) - keep)
                    del buf[: len(buf) - keep]
                return out
            if start:
                h.count("discarded_bytes", start)
                del buf[:start]
            i = 2
            while True:
                i = buf.find(b"\x10", i)
                if i < 0 or i + 1 >= len(buf):
                    if len(buf) > MAX_FRAME:
                        h.count("rejected.too_long")
                        del buf[:2]  # resynchronise on the next start
                        break
                    return out
                nxt = buf[i + 1]
                if nxt == DLE:
                    i += 2
                elif nxt == ETX:
                    out.append(bytes(buf[: i + 2]))
                    del buf[: i + 2]
                    break
                elif nxt == STX:
                    h.count("partial_messages")
                    del buf[:i]
                    break
                else:
                    h.count("rejected.bad_escape")
                    del buf[: i + 2]
                    break

    def end(self) -> None:
        """The connection ended: a message begun and not finished is counted, dropped."""
        if self.buf.startswith(_START) and len(self.buf) > 2:
            self.health.count("partial_messages")
        self.buf.clear()


def unstuff(data: bytes) -> bytes:
    """The BST message inside one framed message (`DLE STX … DLE ETX`), or `Bad`."""
    if len(data) < 4 or not data.startswith(_START) or not data.endswith(b"\x10\x03"):
        raise Bad("bad_frame", f"not a DLE STX … DLE ETX message: {data[:16].hex()}")
    body = data[2:-2]
    i = body.find(b"\x10")
    while i >= 0:
        if body[i + 1 : i + 2] != b"\x10":
            raise Bad("bad_escape", "a DLE inside the message is not doubled")
        i = body.find(b"\x10", i + 2)
    return body.replace(b"\x10\x10", b"\x10")


def _pgn(pf: int, ps: int, dp: int) -> tuple[int, int | None]:
    """(PGN, destination or None) of the PDU format, specific and data-page bytes."""
    if pf < 240:
        return (dp << 16) | (pf << 8), ps
    return (dp << 16) | (pf << 8) | ps, None


def parse(msg: bytes) -> Frame | Message:
    """One BST message (unstuffed: id … checksum) -> a CAN frame or a whole message."""
    if len(msg) < 3:
        raise Bad("bad_length", f"BST message of {len(msg)} bytes")
    if sum(msg) & 0xFF:
        raise Bad("checksum", f"BST {msg[0]:02X}: bytes do not sum to 0 (mod 256)")
    bst = msg[0]
    if bst == 0x93:
        # 93 len prio pgn0 pgn1 pgn2 dst src t0 t1 t2 t3 n data ck
        if len(msg) < 14 or msg[1] != len(msg) - 3 or msg[12] != len(msg) - 14:
            raise Bad("bad_length", f"BST 93 of {len(msg)} bytes, lengths {msg[1]} and {msg[12] if len(msg) > 12 else '-'}")
        pgn = msg[3] | msg[4] << 8 | msg[5] << 16
        if pgn >> 18:
            raise Bad("bad_pgn", f"BST 93 PGN {pgn} beyond 18 bits")
        return Message(msg[2] & 7, pgn, msg[7], msg[6], bytes(msg[13:-1]))
    if bst == 0xD0:
        # D0 len0 len1 dst src PS PF DP/prio control t0 t1 t2 t3 data ck
        length = msg[1] | msg[2] << 8
        if len(msg) < 14 or length != len(msg) - 1:
            raise Bad("bad_length", f"BST D0 of {len(msg)} bytes, length {length}")
        pgn, _ = _pgn(msg[6], msg[5], msg[7] & 3)
        return Message((msg[7] >> 2) & 7, pgn, msg[4], msg[3], bytes(msg[13:-1]))
    if bst == 0x95:
        # 95 len t0 t1 src PS PF DP/prio data ck
        if len(msg) < 9 or msg[1] != len(msg) - 3 or len(msg) - 9 > 8:
            raise Bad("bad_length", f"BST 95 of {len(msg)} bytes, length {msg[1]}")
        pgn, dst = _pgn(msg[6], msg[5], msg[7] & 3)
        return Frame(can_id((msg[7] >> 2) & 7, pgn, msg[4], 255 if dst is None else dst), bytes(msg[8:-1]))
    if bst in _GATEWAY_RX:
        raise Bad("gateway_message", f"BST {bst:02X}: the gateway's own")
    if bst in _GATEWAY_TX:
        raise Bad("gateway_tx", f"BST {bst:02X}: sent to the gateway")
    raise Bad("unknown_bst", f"BST id {bst:02X} is not one this reader knows")


def frame(data: bytes) -> list[Frame | Message]:
    """What one raw record (one framed BST message) carries, for the CAN decoder."""
    return [parse(unstuff(data))]
