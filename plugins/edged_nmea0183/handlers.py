"""One small function per sentence type: fields -> measurements in SI units.

Each handler takes the sentence split at commas (index 0 the address, field positions
from pynmea2's definitions, see `sentences.field_index`) and the decoder's read-only
environment, and returns `Out`. A sentence that says its data is not valid (status
`V`, GGA quality 0, FAA mode `N`) or lacks a field its measurement needs raises
`Invalid`; an empty or malformed number raises ValueError, which the decoder treats
the same way.

Numbers are read strictly (`num`, `count`): NMEA 0183 writes plain decimals, so the
underscores, blanks, exponents, `nan` and `inf` that Python's float() and int() accept
are malformed here. Angles in degrees are checked against the range the standard gives
their field (`angle_deg`, `signed_deg`) and raise `OutOfRange` beyond it, never wrapped:
a heading of 1e308 or −90 is not a heading. Only a sum of in-range angles (magnetic
heading + variation) is wrapped. The other ranges are the measurement kinds' bounds:
the decoder runs `edged.records.validate_measurement` on everything handlers return.
"""

from __future__ import annotations

import math
import re
from typing import Any, Callable


from edged.angles import TWO_PI, wrap_2pi
from .sentences import field_index
from .timeofday import parse_tod
from edged.units import KNOT

KMH = 1.0 / 3.6  # m/s
FOOT = 0.3048  # m
FATHOM = 1.8288  # m
DEG = math.pi / 180.0
DEG_PER_MIN = DEG / 60.0  # rad/s


class Invalid(Exception):
    """The sentence carries no valid data (its own status says so, or fields are empty)."""


class OutOfRange(Invalid):
    """A field holds a number its definition does not allow (a heading of 400°)."""


class Env:
    """What a handler may know beyond its sentence; owned and updated by the decoder."""

    __slots__ = ("variation", "vbw_ground")

    def __init__(self, variation: float | None = None, vbw_ground: bool = False) -> None:
        #: Magnetic variation in degrees, east positive: from the latest RMC, else config.
        self.variation = variation
        self.vbw_ground = vbw_ground


Items = list[tuple[str, dict[str, Any]]]


#: What a handler returns, as a plain tuple (a NamedTuple costs a tenth of the
#: per-sentence budget): (items, the sentence's UTC time of day for `t_src` or None,
#: a magnetic variation in degrees east later sentences may use or None).
Out = tuple[Items, "float | None", "float | None"]


Handler = Callable[[list[str], Env], Out]


# ---- field helpers -----------------------------------------------------------------

#: The characters of an NMEA 0183 decimal. float() of a string made of these alone
#: accepts exactly an optional sign and digits with an optional fraction (`.5`, `5.`)
#: and raises for the rest ("", ".", "1.2.3", "5-"): no blanks, underscores,
#: exponents, nan or inf. (A character class is half the cost of the full grammar.)
_DECIMAL = re.compile(r"[-+.0-9]+").fullmatch
_DIGITS = re.compile(r"[0-9]+").fullmatch


def num(s: str) -> float:
    """A numeric field, strictly; ValueError when empty or malformed."""
    if _DECIMAL(s) is None:
        raise ValueError(f"not an NMEA number: {s!r}")
    return float(s)


def count(s: str) -> int:
    """An unsigned integer field (fix quality, satellites), strictly."""
    if _DIGITS(s) is None:
        raise ValueError(f"not an NMEA integer: {s!r}")
    return int(s)


def _opt(s: str) -> float | None:
    return num(s) if s else None


def direction_deg(s: str, what: str) -> float:
    """A direction field in degrees, checked to lie in [0, 360]; −0 comes back as 0."""
    v = num(s)
    if not 0.0 <= v <= 360.0:
        raise OutOfRange(f"{what} outside [0, 360]")  # no value: logged once per kind
    return v + 0.0  # + 0.0: −0.0 becomes 0.0


def angle_deg(s: str, what: str) -> float:
    """A direction in degrees, [0, 360] (360 is north, as 0) -> radians in [0, 2π)."""
    r = direction_deg(s, what) * DEG
    return r if r < TWO_PI else 0.0  # 360, or a hair below that rounds to 2π


def signed_deg(v: float, what: str) -> float:
    """A signed angle in degrees (variation, deviation) checked to lie in [−180, 180]."""
    if not -180.0 <= v <= 180.0:
        raise OutOfRange(f"{what} outside [-180, 180]")
    return v


def _lat(value: str, hemi: str) -> float:
    """`ddmm.mmmm` + N/S -> signed decimal degrees (empty -> Invalid)."""
    v = num(value)  # empty: ValueError, which the decoder counts as invalid
    deg = v // 100.0
    minutes = v - deg * 100.0
    if minutes >= 60.0 or v < 0.0:
        raise Invalid("minutes out of range")
    if hemi == "N":
        return deg + minutes / 60.0 + 0.0  # + 0.0: "-0000.00" gives 0.0, not -0.0
    if hemi == "S":
        return 0.0 - (deg + minutes / 60.0)  # 0.0 - x: S of 0 is 0.0, not -0.0
    raise Invalid("hemisphere")


def _lon(value: str, hemi: str) -> float:
    """`dddmm.mmmm` + E/W -> signed decimal degrees (empty -> Invalid)."""
    v = num(value)
    deg = v // 100.0
    minutes = v - deg * 100.0
    if minutes >= 60.0 or v < 0.0:
        raise Invalid("minutes out of range")
    if hemi == "E":
        return deg + minutes / 60.0 + 0.0
    if hemi == "W":
        return 0.0 - (deg + minutes / 60.0)
    raise Invalid("hemisphere")


def _signed(value: str, direction: str) -> float | None:
    """A deviation/variation `x.x,E|W` in degrees, east positive; None when empty.

    Not range-checked here: RMC's variation is judged by the decoder on its own (a bad
    one must not reject the fix), the others by `signed_deg`.
    """
    if not value:
        return None
    v = num(value)
    if direction == "W":
        return -v
    if direction == "E":
        return v
    raise Invalid("variation direction")


def _faa_invalid(mode: str) -> bool:
    """FAA mode indicator (NMEA 2.3+): `N` = data not valid; absent = older talker."""
    return mode[:1] == "N"


def _heading(magnetic_deg: float, variation: float | None) -> Items:
    """A magnetic heading becomes true when a variation is known (DESIGN §2).

    Both are in range (checked by the callers), so the sum is wrapped.
    """
    if variation is None:
        return [("heading_magnetic", {"heading": wrap_2pi(magnetic_deg * DEG)})]
    return [("heading", {"heading": wrap_2pi((magnetic_deg + variation) * DEG)})]


# ---- handlers ----------------------------------------------------------------------

_GGA = field_index("GGA", "timestamp", "lat", "lat_dir", "lon", "lon_dir", "gps_qual", "num_sats", "horizontal_dil")


def gga(f: list[str], env: Env) -> Out:
    ts, la, lad, lo, lod, q, sats, hdop = _GGA
    quality = count(f[q])
    if quality == 0:
        raise Invalid("fix quality 0")
    if quality > 8:  # NMEA 0183 defines 0-8
        raise OutOfRange("fix quality outside 0-8")
    h = f[hdop]
    n = f[sats]
    pos = {
        "lat": _lat(f[la], f[lad]),
        "lon": _lon(f[lo], f[lod]),
        "fix_quality": quality,
        "hdop": num(h) if h else None,
        "sats": count(n) if n else None,
    }
    return [("position", pos)], parse_tod(f[ts]), None


#: GNS mode characters (one per constellation) -> the GGA fix quality they correspond to.
_GNS_QUALITY = {"A": 1, "D": 2, "P": 3, "R": 4, "F": 5, "E": 6, "M": 7, "S": 8}
_GNS = field_index("GNS", "timestamp", "lat", "lat_dir", "lon", "lon_dir", "mode_indicator", "num_sats", "hdop")


def gns(f: list[str], env: Env) -> Out:
    ts, la, lad, lo, lod, mode, sats, hdop = _GNS
    qualities = [_GNS_QUALITY[c] for c in f[mode] if c in _GNS_QUALITY]
    if not qualities:
        raise Invalid("no constellation has a fix")
    pos = {
        "lat": _lat(f[la], f[lad]),
        "lon": _lon(f[lo], f[lod]),
        "fix_quality": max(qualities),
        "hdop": _opt(f[hdop]),
        "sats": count(f[sats]) if f[sats] else None,
    }
    return [("position", pos)], parse_tod(f[ts]), None


_RMC = field_index(
    "RMC", "timestamp", "status", "lat", "lat_dir", "lon", "lon_dir", "spd_over_grnd", "true_course",
    "mag_variation", "mag_var_dir", "mode_indicator",
)


def rmc(f: list[str], env: Env) -> Out:
    ts, st, la, lad, lo, lod, sog, cog, var, vard, mode = _RMC
    if f[st] != "A" or _faa_invalid(f[mode]):
        raise Invalid("status")
    items: Items = [("position", {"lat": _lat(f[la], f[lad]), "lon": _lon(f[lo], f[lod])})]
    try:
        variation = _signed(f[var], f[vard])
    except (ValueError, Invalid):
        # A malformed variation is not a reason to drop a valid fix: NaN hands it to
        # the decoder, which rejects the variation alone and keeps the one it had.
        variation = math.nan
    if f[sog]:
        course = f[cog]
        try:
            cog_rad = angle_deg(course, "course") if course else None
        except OutOfRange:
            # NaN: validation rejects (and counts) the velocity only; the fix stays.
            cog_rad = math.nan
        items.append(("velocity_ground", {"sog": num(f[sog]) * KNOT, "cog": cog_rad}))
    return items, parse_tod(f[ts]), variation


_GLL = field_index("GLL", "lat", "lat_dir", "lon", "lon_dir", "timestamp", "status", "faa_mode")


def gll(f: list[str], env: Env) -> Out:
    la, lad, lo, lod, ts, st, mode = _GLL
    status = f[st]
    if (status and status != "A") or _faa_invalid(f[mode]):  # pre-2.0 GLL has no status
        raise Invalid("status")
    pos = {"lat": _lat(f[la], f[lad]), "lon": _lon(f[lo], f[lod])}
    return [("position", pos)], parse_tod(f[ts]), None


_VTG = field_index("VTG", "true_track", "spd_over_grnd_kts", "spd_over_grnd_kmph", "faa_mode")


def vtg(f: list[str], env: Env) -> Out:
    cog, kts, kmh, mode = _VTG
    if _faa_invalid(f[mode]):
        raise Invalid("mode N")
    if f[kts]:
        sog = num(f[kts]) * KNOT
    elif f[kmh]:
        sog = num(f[kmh]) * KMH
    else:
        raise Invalid("no speed")
    course = f[cog]
    return [("velocity_ground", {"sog": sog, "cog": angle_deg(course, "course") if course else None})], None, None


_HDT = field_index("HDT", "heading")


def hdt(f: list[str], env: Env) -> Out:
    return [("heading", {"heading": angle_deg(f[_HDT[0]], "heading")})], None, None


_THS = field_index("THS", "heading", "mode")
_THS_VALID = frozenset("AEM")  # autonomous, estimated (dead reckoning), manual input


def ths(f: list[str], env: Env) -> Out:
    h, mode = _THS
    if f[mode] not in _THS_VALID:
        raise Invalid("mode")  # V invalid, S simulator
    return [("heading", {"heading": angle_deg(f[h], "heading")})], None, None


_HDG = field_index("HDG", "heading", "deviation", "dev_dir", "variation", "var_dir")


def hdg(f: list[str], env: Env) -> Out:
    h, dev, devd, var, vard = _HDG
    sensor = direction_deg(f[h], "magnetic sensor heading")
    deviation = _signed(f[dev], f[devd])
    magnetic = sensor + (0.0 if deviation is None else signed_deg(deviation, "deviation"))
    own = _signed(f[var], f[vard])
    if own is not None:
        # A bad variation in this HDG rejects this HDG only (its heading needs it);
        # the decoder's variation is not touched.
        signed_deg(own, "variation")
    return _heading(magnetic, own if own is not None else env.variation), None, None


_HDM = field_index("HDM", "heading")


def hdm(f: list[str], env: Env) -> Out:
    return _heading(direction_deg(f[_HDM[0]], "magnetic heading"), env.variation), None, None


_ROT = field_index("ROT", "rate_of_turn", "status")


def rot(f: list[str], env: Env) -> Out:
    r, st = _ROT
    if f[st] != "A":
        raise Invalid("status")
    return [("yaw_rate", {"r": num(f[r]) * DEG_PER_MIN})], None, None  # any sign


_VBW = field_index(
    "VBW", "lon_water_spd", "trans_water_spd", "data_validity_water_spd", "lon_grnd_spd", "trans_grnd_spd",
    "data_validity_grnd_spd",
)


def vbw(f: list[str], env: Env) -> Out:
    wl, wt, wst, gl, gt, gst = _VBW
    items: Items = []
    water_ok = f[wst] == "A" and bool(f[wl])
    ground_ok = f[gst] == "A" and bool(f[gl])
    if not water_ok and not ground_ok:
        raise Invalid("status")
    if water_ok:
        items.append(("water_speed", {"stw_long": num(f[wl]) * KNOT, "stw_trans": _knots(f[wt])}))
    if ground_ok and env.vbw_ground:
        # Ground speeds are along/across the hull: their direction needs the heading,
        # so only the speed is stated here.
        sog = math.hypot(num(f[gl]), num(f[gt]) if f[gt] else 0.0) * KNOT
        items.append(("velocity_ground", {"sog": sog, "cog": None}))
    return items, None, None


def _knots(s: str) -> float | None:
    return num(s) * KNOT if s else None


_VHW = field_index("VHW", "water_speed_knots", "water_speed_km")


def vhw(f: list[str], env: Env) -> Out:
    kts, kmh = _VHW
    if f[kts]:
        stw = num(f[kts]) * KNOT
    elif f[kmh]:
        stw = num(f[kmh]) * KMH
    else:
        raise Invalid("no speed")
    return [("water_speed", {"stw_long": stw, "stw_trans": None})], None, None


_VDR = field_index("VDR", "deg_t", "deg_m", "current")


def vdr(f: list[str], env: Env) -> Out:
    true, mag, drift = _VDR
    if f[true]:
        set_rad = angle_deg(f[true], "set")
    elif f[mag] and env.variation is not None:
        set_rad = wrap_2pi((direction_deg(f[mag], "magnetic set") + env.variation) * DEG)
    else:
        raise Invalid("no set")
    return [("current", {"set": set_rad, "drift": num(f[drift]) * KNOT})], None, None


_DPT = field_index("DPT", "depth", "offset")


def dpt(f: list[str], env: Env) -> Out:
    d, off = _DPT
    return [("depth", {"depth": num(f[d]), "offset": _opt(f[off])})], None, None


_DBT = field_index("DBT", "depth_feet", "depth_meters", "depth_fathoms")


def dbt(f: list[str], env: Env) -> Out:
    ft, m, fa = _DBT
    if f[m]:
        depth = num(f[m])
    elif f[ft]:
        depth = num(f[ft]) * FOOT
    elif f[fa]:
        depth = num(f[fa]) * FATHOM
    else:
        raise Invalid("no depth")
    return [("depth", {"depth": depth, "offset": None})], None, None


_ZDA = field_index("ZDA", "timestamp")


def zda(f: list[str], env: Env) -> Out:
    """Time only (the replay reader takes the date); no measurement."""
    return [], parse_tod(f[_ZDA[0]]), None


#: Sentence type (talker stripped) -> handler. Everything else is `unknown.<TYPE>`.
HANDLERS: dict[str, Handler] = {
    "GGA": gga,
    "GNS": gns,
    "RMC": rmc,
    "GLL": gll,
    "VTG": vtg,
    "HDT": hdt,
    "THS": ths,
    "HDG": hdg,
    "HDM": hdm,
    "ROT": rot,
    "VBW": vbw,
    "VHW": vhw,
    "VDR": vdr,
    "DPT": dpt,
    "DBT": dbt,
    "ZDA": zda,
}
