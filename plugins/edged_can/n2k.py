"""NMEA 2000 frames of one bus -> measurements (DESIGN §2 kinds, §5 PGN list).

Field layouts come from canboat through `n2k_codec`; what each PGN means for edged
(which kind, which reference, what makes it invalid) is here, one small handler per
PGN in a table. State that spans messages — fast-packets in flight, the magnetic
variation last heard, which device holds which address — lives in this object, which
the runtime keeps per bus, so it also spans the files of one replay.

Values are taken as canboat decodes them and never wrapped into range: a heading or
COG must lie in [0, 2π) (canboat's 16-bit angles reach 6.5535 rad, and 0xFFFC, just
below its "unavailable"/"error" markers, decodes as 6.5532), a variation or deviation
in [−π, π]; anything else is not a value and is counted `rejected.invalid_value`.
Only sums of in-range angles (magnetic heading + variation) are wrapped.
"""

from __future__ import annotations

import math
from typing import Any, Callable

from edged.angles import TWO_PI, wrap_2pi
from edged.health import ComponentHealth
from edged.records import Measurement, RawRecord

from . import n2k_codec
from .config import CanConfig
from .emit import Emitter
from .fastpacket import FastPacketAssembler
from .sources import N2kSources

# canboat lookup codes used below.
_REF_TRUE, _REF_MAGNETIC = 0, 1  # DIRECTION_REFERENCE
_GNSS_NO_FIX, _GNSS_ERROR = 0, 14  # GNS_METHOD; 1..8 match NMEA 0183 GGA fix quality
_GNSS_UNAVAILABLE = 15  # the 4-bit field's "not available"
_GNSS_LAST_DEFINED = 8
_DAY = 86400.0
#: Seconds around a reassembled message within which frames of the same source and
#: PGN are taken as its copies (a fast-packet PGN repeats at 1 Hz or slower).
WHOLE_WINDOW = 5.0

Handler = Callable[[dict[str, Any], bytes, int, float, list[Measurement]], None]


def _utc(days: Any, seconds: Any) -> float | None:
    if days is None or seconds is None:
        return None
    return float(days) * _DAY + float(seconds)


def _tod_ok(seconds: Any) -> bool:
    """A time of day is in [0, 86401): 86400.x is the leap second 23:59:60.x."""
    return seconds is None or 0.0 <= seconds < _DAY + 1.0


#: NMEA 2000 angles are 0.0001 rad counts: a sensor reading 359.999° sends 62832, which
#: is 6.2832 rad, a hair above 2π. Up to one count beyond 2π is north; 0xFFFC (6.5532)
#: and the like are not directions.
_ANGLE_LSB = 1e-4


def _direction(a: Any) -> float | None:
    """A heading/COG in [0, 2π), or None when it is not one (beyond 2π, negative)."""
    a = float(a)
    if 0.0 <= a < TWO_PI:
        return a + 0.0  # + 0.0: −0.0 becomes 0.0
    if TWO_PI <= a <= TWO_PI + _ANGLE_LSB:
        return 0.0  # 360° quantised upward
    return None


def _signed_angle(a: Any) -> float | None:
    """A variation/deviation in [−π, π], or None when it is not one."""
    a = float(a)
    return a if -math.pi <= a <= math.pi else None


class N2kDecoder:
    def __init__(self, bus: str, config: CanConfig, health: ComponentHealth, emit: Emitter) -> None:
        self._health = health
        self._emit = emit
        self._sources = N2kSources(bus, config.source_names, config.iso_name_map(), health)
        self._fast = FastPacketAssembler(health)
        deg = config.magnetic_variation_deg
        self._variation_config = None if deg is None else math.radians(deg)
        self._variation_pgn: float | None = None
        self._handlers: dict[int, Handler] = {
            127250: self._heading,
            127251: self._rate_of_turn,
            127257: self._attitude,
            127258: self._variation,
            128259: self._water_speed,
            128267: self._depth,
            129025: self._position_rapid,
            129026: self._cog_sog,
            129029: self._gnss_position,
            126992: self._system_time,
            60928: self._address_claim,
        }
        self._pgn_keys = {pgn: f"pgn.{pgn}" for pgn in self._handlers}
        self._fast_pgns = {pgn for pgn in self._handlers if n2k_codec.is_fast(pgn)}
        #: (source, PGN) whose messages a gateway hands over reassembled -> the time of
        #: the last such message (frames of that key are its copies only near it).
        self._whole: dict[tuple[int, int], float] = {}
        #: The last message the assembler completed per (source, PGN): (t, payload).
        self._assembled: dict[tuple[int, int], tuple[float, bytes]] = {}

    def decode(self, raw: RawRecord, can_id: int) -> list[Measurement]:
        prio, pgn, addr, dst = n2k_codec.split_id(can_id)
        handler = self._handlers.get(pgn)
        data = raw.data
        if handler is None:
            self._count_unknown(pgn, data)
            return []
        if pgn in self._fast_pgns:
            whole_t = self._whole.get((addr, pgn))
            if whole_t is not None and abs(raw.t - whole_t) <= WHOLE_WINDOW:
                # The gateway also writes this PGN reassembled (PLAIN_MIX_FAST): that
                # copy is the one decoded; its frames are counted and left.
                self._health.count("duplicates.fast_frames")
                return []
            payload = self._fast.push(addr, pgn, data)
            if payload is None:
                return []
            self._assembled[(addr, pgn)] = (raw.t, payload)
        else:
            payload = data
        return self._message(raw, handler, prio, pgn, addr, dst, payload)

    def decode_message(self, raw: RawRecord, prio: int, pgn: int, addr: int, dst: int, payload: bytes) -> list[Measurement]:
        """A whole message a gateway reassembled (or a single-frame PGN it passed on)."""
        handler = self._handlers.get(pgn)
        if handler is None:
            self._health.count(f"unknown_pgn.{pgn}")
            return []
        if pgn in self._fast_pgns:
            key = (addr, pgn)
            self._whole[key] = raw.t
            done = self._assembled.pop(key, None)
            if done is not None and done[1] == payload and raw.t - done[0] <= 1.0:
                # The same message just came in as frames (before this key was known
                # to be reassembled by the gateway): decoded once already.
                self._health.count("duplicates.fast_messages")
                return []
        return self._message(raw, handler, prio, pgn, addr, dst, payload)

    def _message(self, raw: RawRecord, handler: Handler, prio: int, pgn: int, addr: int, dst: int,
                 payload: bytes) -> list[Measurement]:
        fields = n2k_codec.decode_fields(pgn, payload, addr, dst, prio)
        if fields is None:
            self._health.count("rejected.undecodable")
            self._health.error(f"PGN {pgn} from {addr}: canboat cannot decode {payload.hex()}")
            return []
        self._health.count(self._pgn_keys[pgn])
        out: list[Measurement] = []
        handler(fields, payload, addr, raw.t, out)
        return out

    def _count_unknown(self, pgn: int, data: bytes) -> None:
        # One count per message: a fast-packet message counts at its first frame.
        if data and n2k_codec.is_fast(pgn) and data[0] & 0x1F:
            return
        self._health.count(f"unknown_pgn.{pgn}")

    def _bad(self, src: str, what: str) -> None:
        """A value canboat decoded that cannot be true: counted like a failed validation,
        one message per source and field (not per value)."""
        self._health.count("rejected.invalid_value")
        self._health.error(f"{src}: {what}")

    def _variation_known(self, same_pgn: Any) -> float | None:
        """DESIGN §2: the same PGN's variation, else PGN 127258's, else configuration.

        The same PGN's variation is range-checked by the caller."""
        if same_pgn is not None:
            return float(same_pgn)
        if self._variation_pgn is not None:
            return self._variation_pgn
        return self._variation_config

    # ---- one handler per PGN -------------------------------------------------------

    def _heading(self, f: dict[str, Any], _p: bytes, addr: int, t: float, out: list[Measurement]) -> None:
        hdg, ref = f.get("heading"), f.get("reference")
        if hdg is None:
            self._emit.unavailable("127250")
            return
        src = self._sources.name(addr)
        heading = _direction(hdg)
        if heading is None:
            self._bad(src, "PGN 127250 heading outside [0, 2π)")
            return
        if ref == _REF_TRUE:
            self._emit(out, "heading", src, t, {"heading": heading})
        elif ref == _REF_MAGNETIC:
            dev, own = f.get("deviation"), f.get("variation")
            if dev is not None and _signed_angle(dev) is None:
                self._bad(src, "PGN 127250 deviation outside [-π, π]")
                return
            if own is not None and _signed_angle(own) is None:
                # This message's heading needs it: the message goes, the variation
                # known from 127258 or the configuration stays.
                self._bad(src, "PGN 127250 variation outside [-π, π]")
                return
            magnetic = heading + (dev or 0.0)
            var = self._variation_known(own)
            if var is None:
                self._emit(out, "heading_magnetic", src, t, {"heading": wrap_2pi(magnetic)})
            else:
                self._emit(out, "heading", src, t, {"heading": wrap_2pi(magnetic + var)})
        else:
            self._health.count("rejected.heading_reference")
            self._health.error(f"{src}: PGN 127250 heading reference {ref!r} is neither true nor magnetic")

    def _rate_of_turn(self, f: dict[str, Any], _p: bytes, addr: int, t: float, out: list[Measurement]) -> None:
        rate = f.get("rate")
        if rate is None:
            self._emit.unavailable("127251")
            return
        self._emit(out, "yaw_rate", self._sources.name(addr), t, {"r": float(rate)})

    def _attitude(self, f: dict[str, Any], _p: bytes, addr: int, t: float, out: list[Measurement]) -> None:
        roll, pitch = f.get("roll"), f.get("pitch")
        if roll is None or pitch is None:
            self._emit.unavailable("127257")
            return
        self._emit(out, "attitude", self._sources.name(addr), t, {"roll": float(roll), "pitch": float(pitch)})

    def _variation(self, f: dict[str, Any], _p: bytes, addr: int, _t: float, _out: list[Measurement]) -> None:
        var = f.get("variation")
        if var is None:
            self._emit.unavailable("127258")
            return
        good = _signed_angle(var)
        if good is None:
            # Rejected by itself: the last good (or configured) variation stays in use.
            self._bad(self._sources.name(addr), "PGN 127258 variation outside [-π, π]")
            return
        self._variation_pgn = good

    def _water_speed(self, f: dict[str, Any], _p: bytes, addr: int, t: float, out: list[Measurement]) -> None:
        stw = f.get("speedWaterReferenced")
        if stw is None:
            self._emit.unavailable("128259")
            return
        self._emit(out, "water_speed", self._sources.name(addr), t, {"stw_long": float(stw)})

    def _depth(self, f: dict[str, Any], _p: bytes, addr: int, t: float, out: list[Measurement]) -> None:
        depth = f.get("depth")
        if depth is None:
            self._emit.unavailable("128267")
            return
        values = {"depth": float(depth)}
        if f.get("offset") is not None:
            values["offset"] = float(f["offset"])  # + transducer to waterline, as NMEA
        self._emit(out, "depth", self._sources.name(addr), t, values)

    def _position_rapid(self, f: dict[str, Any], _p: bytes, addr: int, t: float, out: list[Measurement]) -> None:
        lat, lon = f.get("latitude"), f.get("longitude")
        if lat is None or lon is None:
            self._emit.unavailable("129025")
            return
        self._emit(out, "position", self._sources.name(addr), t, {"lat": float(lat), "lon": float(lon)})

    def _cog_sog(self, f: dict[str, Any], _p: bytes, addr: int, t: float, out: list[Measurement]) -> None:
        sog, cog, ref = f.get("sog"), f.get("cog"), f.get("cogReference")
        if sog is None:
            self._emit.unavailable("129026")
            return
        values: dict[str, Any] = {"sog": float(sog)}
        if cog is not None:
            cog = _direction(cog)
            if cog is None:
                self._bad(self._sources.name(addr), "PGN 129026 COG outside [0, 2π)")
                return
        if cog is not None and ref == _REF_TRUE:
            values["cog"] = cog
        elif cog is not None and ref == _REF_MAGNETIC:
            var = self._variation_known(None)
            if var is None:
                self._emit.unavailable("129026.cog_true")  # magnetic COG, no variation known
            else:
                values["cog"] = wrap_2pi(cog + var)
        self._emit(out, "velocity_ground", self._sources.name(addr), t, values)

    def _gnss_position(self, f: dict[str, Any], _p: bytes, addr: int, t: float, out: list[Measurement]) -> None:
        lat, lon, method = f.get("latitude"), f.get("longitude"), f.get("method")
        src = self._sources.name(addr)
        if method in (_GNSS_NO_FIX, _GNSS_ERROR):
            self._health.count("rejected.no_fix")
            self._health.error(f"{src}: PGN 129029 without a GNSS fix")
            return
        if method is not None and method != _GNSS_UNAVAILABLE and not 0 < method <= _GNSS_LAST_DEFINED:
            # 9-13: codes canboat does not define; a fix of unknown quality is not used.
            self._bad(src, "PGN 129029 GNSS method outside the defined 0-8, 14, 15")
            return
        if lat is None or lon is None:
            self._emit.unavailable("129029")
            return
        values: dict[str, Any] = {"lat": float(lat), "lon": float(lon)}
        if method is not None and method != _GNSS_UNAVAILABLE:
            values["fix_quality"] = int(method)  # 15 "unavailable" is no fix quality
        if f.get("numberOfSvs") is not None:
            values["sats"] = int(f["numberOfSvs"])
        if f.get("hdop") is not None:
            values["hdop"] = float(f["hdop"])
        tod = f.get("time")
        if not _tod_ok(tod):
            # The position stands on its own (t is our receive time); only the
            # device's time is dropped, counted, and logged once per source.
            self._health.count("rejected.bad_time_of_day")
            self._health.error(f"{src}: PGN 129029 time of day beyond 86400 s, t_src dropped")
            tod = None
        self._emit(out, "position", src, t, values, _utc(f.get("date"), tod))

    def _system_time(self, f: dict[str, Any], _p: bytes, addr: int, t: float, _out: list[Measurement]) -> None:
        # No measurement kind carries time; the offset of the device's clock to ours is
        # what a reviewer of a recording wants to see.
        tod = f.get("time")
        if not _tod_ok(tod):
            self._health.count("rejected.bad_time_of_day")
            self._health.error(f"{self._sources.name(addr)}: PGN 126992 time of day beyond 86400 s")
            return
        t_src = _utc(f.get("date"), tod)
        if t_src is None:
            self._emit.unavailable("126992")
            return
        self._health.info.setdefault("clock_offset_s", {})[self._sources.name(addr)] = round(t_src - t, 3)

    def _address_claim(self, _f: dict[str, Any], payload: bytes, addr: int, _t: float, _o: list[Measurement]) -> None:
        if len(payload) < 8:
            self._health.count("rejected.short_address_claim")
            self._health.error(f"address claim from {addr} shorter than 8 bytes")
            return
        self._sources.claim(addr, int.from_bytes(payload[:8], "little"))
