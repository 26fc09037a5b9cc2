"""The PGNs the NMEA 2000 output sends, made from the fused values (`BridgeView`).

Each PGN is a `Message` (its name is its number, the key of `rates`) with the roles
it is made of, its default rate and its priority, and a function that gives its
fields (canboat's field ids, SI units) from the view. A value the view holds as None
(stale, converging, missing, too old) is left out and goes out as the field's "no
data" code: a receiver never takes a stale number for a measurement.

- 128259 Speed: water referenced = the STW estimate's `stw`; ground referenced = the
  manoeuvring state's `sog`; speed type "no data" unless configured (none of the
  standard's sensor types is a fused estimate).
- 130577 Direction Data (fast-packet): COG and SOG (manoeuvre, true), heading
  (manoeuvre), STW, set and drift of the current (stw's `current_set`, `current`).
- 127250 Vessel Heading: true heading, reference True, no deviation or variation.
- 127251 Rate of Turn: the yaw rate, + to starboard (3.125e-08 rad/s resolution).
- 128000 Leeway: the drift angle through the water, + when the vessel slips to
  starboard (manoeuvre `drift_angle_water`).
- 129026 COG & SOG, Rapid Update: true COG and SOG of the manoeuvring state.

Every one of them has a sequence ID (SID): the same for the PGNs made from the same
estimates (`Sid`), so that a receiver can tell which values belong together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

from edged.bridgeoutput import Message
from edged.bridgeview import BridgeView

__all__ = ["PGNS", "Pgn", "Sid", "fields_of"]

_TRUE = 0  # DIRECTION_REFERENCE "True"
_AUTONOMOUS = 0  # RESIDUAL_MODE: values from measurements, not dead reckoning
#: Largest value of an unsigned 16-bit 0.01 m/s speed (655.32; above are the codes).
_MAX_SPEED = 655.32
#: N2K angles are 0.0001 rad: [0, 2π) ends at 62831, 2π itself is north.
_TWO_PI = 2.0 * math.pi

Fields = Callable[[BridgeView, dict[str, Any]], dict[str, Any]]


@dataclass(frozen=True, slots=True)
class Pgn:
    """One PGN we send: the bridge message, its priority, how its fields are made."""

    message: Message
    prio: int
    fields: Fields


def _speed(v: float | None) -> float | None:
    """A speed the unsigned field can carry (a negative estimate is no speed over
    ground or through water an instrument may show; above the range: no data)."""
    if v is None or not 0.0 <= v <= _MAX_SPEED:
        return None
    return v


def _direction(a: float | None) -> float | None:
    """An angle in [0, 2π) (a direction field is unsigned)."""
    return None if a is None else a % _TWO_PI


def _signed(a: float | None) -> float | None:
    """An angle in [−π, π) (leeway; a signed 16-bit 0.0001 rad field)."""
    return None if a is None else (a + math.pi) % _TWO_PI - math.pi


def _speed_128259(v: BridgeView, opt: dict[str, Any]) -> dict[str, Any]:
    return {"speedWaterReferenced": _speed(v.get("stw", "stw")),
            "speedGroundReferenced": _speed(v.get("manoeuvre", "sog")),
            "speedWaterReferencedType": opt.get("stw_sensor_type")}


def _direction_130577(v: BridgeView, _o: dict[str, Any]) -> dict[str, Any]:
    return {"dataMode": _AUTONOMOUS, "cogReference": _TRUE,
            "cog": _direction(v.get("manoeuvre", "cog")), "sog": _speed(v.get("manoeuvre", "sog")),
            "heading": _direction(v.get("manoeuvre", "heading")),
            "speedThroughWater": _speed(v.get("stw", "stw")),
            "set": _direction(v.get("stw", "current_set")), "drift": _speed(v.get("stw", "current"))}


def _heading_127250(v: BridgeView, _o: dict[str, Any]) -> dict[str, Any]:
    return {"heading": _direction(v.get("manoeuvre", "heading")), "reference": _TRUE}


def _rate_127251(v: BridgeView, _o: dict[str, Any]) -> dict[str, Any]:
    r = v.get("manoeuvre", "r")
    # The signed 32-bit field reaches ±67.1 rad/s; beyond that: no data.
    return {"rate": r if r is not None and abs(r) < 67.0 else None}


def _leeway_128000(v: BridgeView, _o: dict[str, Any]) -> dict[str, Any]:
    return {"leewayAngle": _signed(v.get("manoeuvre", "drift_angle_water"))}


def _cog_sog_129026(v: BridgeView, _o: dict[str, Any]) -> dict[str, Any]:
    return {"cogReference": _TRUE, "cog": _direction(v.get("manoeuvre", "cog")),
            "sog": _speed(v.get("manoeuvre", "sog"))}


def _pgn(number: int, roles: tuple[str, ...], hz: float, prio: int, fields: Fields) -> Pgn:
    return Pgn(Message(str(number), frozenset(roles), hz), prio, fields)


#: The PGNs, by name (their number as text); default rates and priorities are the
#: standard's (canboat's transmission intervals where it has one). 128259 and 130577
#: go with each STW estimate (1 Hz), the manoeuvring state's latest values beside it.
PGNS: dict[str, Pgn] = {p.message.name: p for p in (
    _pgn(128259, ("stw",), 1.0, 2, _speed_128259),
    _pgn(130577, ("stw",), 1.0, 3, _direction_130577),
    _pgn(127250, ("manoeuvre",), 10.0, 2, _heading_127250),
    _pgn(127251, ("manoeuvre",), 10.0, 2, _rate_127251),
    _pgn(128000, ("manoeuvre",), 1.0, 4, _leeway_128000),
    _pgn(129026, ("manoeuvre",), 4.0, 2, _cog_sog_129026),
)}


class Sid:
    """The sequence ID: one value for all PGNs made from the estimates of one data
    time, the next (0-252, wrapping) when the data time moves on."""

    __slots__ = ("value", "_t")

    def __init__(self) -> None:
        self.value = 0
        self._t: float | None = None

    def at(self, t: float | None) -> int:
        if t != self._t:
            if self._t is not None:
                self.value = (self.value + 1) % 253
            self._t = t
        return self.value


def fields_of(pgn: Pgn, view: BridgeView, sid: int, options: dict[str, Any]) -> dict[str, Any]:
    """The fields of `pgn` now, SID included."""
    f = pgn.fields(view, options)
    f["sid"] = sid
    return f
