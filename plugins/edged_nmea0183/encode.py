"""NMEA 0183 sentences of the fused values (the `nmea0183` output, issue 35).

One function per sentence, each from the bridge view (SI units, None where a value
must not go out as a number) to the sentence's text with its checksum and line end.
Fields follow NMEA 0183 v4.11; a value that is not available is an empty field,
and a sentence with a status field says `V` (void) there, never a stale number:

- `VHW`  heading (°T), STW (kn and km/h); the magnetic heading is left empty;
- `VBW`  longitudinal and transverse speed through the water (stw) and over the
  ground (manoeuvre's u, v), kn, + forward and + starboard, each pair with its
  status; the stern's transverse speeds are left empty (status V);
- `VDR`  set of the current (°T) and drift (kn);
- `HDT`  true heading (°);
- `ROT`  rate of turn (°/min, − to port) with its status;
- `XDR`  the draft marks' wave-free means, the mean draft, trim and list, as
  transducer readings of type `D` (linear displacement) in metres, named
  `DRAFT_<mark's initials>` (fore_port: `DRAFT_FP`), `DRAFT_MEAN`, `TRIM` (aft − fore,
  + by the stern) and `LIST` (port − starboard); as many sentences as the 82-character
  limit needs.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Sequence

from edged.units import KNOT

from edged.bridgeview import BridgeView

from .lines import nmea_checksum

__all__ = ["SENTENCES", "sentence", "xdr_name", "MAX_SENTENCE"]

#: The longest sentence NMEA 0183 allows, `$` to the line end included.
MAX_SENTENCE = 82
#: The largest magnitude each kind of field carries (kn, km/h, °/min, m). Beyond it (a
#: filter that diverged) the field is "not available", its status V: a sentence never
#: outgrows its 82 characters, and no instrument is handed an absurd number.
MAX_KNOTS, MAX_KMH, MAX_ROT, MAX_METRES = 999.99, 1999.99, 9999.9, 99.99
_KMH = 1000.0 / 3600.0
_DEG = 180.0 / math.pi


def sentence(talker: str, kind: str, fields: Sequence[str]) -> bytes:
    """`$<talker><kind>,<fields>*<checksum>\\r\\n` as bytes."""
    body = f"{talker}{kind},{','.join(fields)}".encode("ascii")
    return b"$%s*%02X\r\n" % (body, nmea_checksum(body))


def _num(v: float | None, decimals: int) -> str:
    if v is None:
        return ""
    s = f"{v:.{decimals}f}"
    return s[1:] if s.startswith("-") and float(s) == 0.0 else s  # no "-0.0"


def _bearing(rad: float | None) -> str:
    """Degrees true in [0, 360) at 0.1°, 360.0 after rounding made 0.0."""
    if rad is None:
        return ""
    s = f"{math.degrees(rad) % 360.0:.1f}"
    return "0.0" if s == "360.0" else s


def _status(*values: float | None) -> str:
    return "A" if all(v is not None for v in values) else "V"


def _ratio(v: float | None, unit: float, limit: float) -> float | None:
    """`v` in `unit`s, None beyond `limit`."""
    if v is None:
        return None
    x = v / unit
    return x if abs(x) <= limit else None


def _metres(v: float | None) -> float | None:
    return _ratio(v, 1.0, MAX_METRES)


def vhw(view: BridgeView, talker: str) -> bytes:
    stw = view.get("stw", "stw")
    kn, kmh = _ratio(stw, KNOT, MAX_KNOTS), _ratio(stw, _KMH, MAX_KMH)
    if kn is None or kmh is None:
        kn = kmh = None
    return sentence(talker, "VHW", (_bearing(view.get("manoeuvre", "heading")), "T", "", "M",
                                    _num(kn, 2), "N", _num(kmh, 2), "K"))


def vbw(view: BridgeView, talker: str) -> bytes:
    wl, wt = (_ratio(view.get("stw", f), KNOT, MAX_KNOTS) for f in ("stw_long", "stw_trans"))
    gl, gt = (_ratio(view.get("manoeuvre", f), KNOT, MAX_KNOTS) for f in ("u", "v"))
    return sentence(talker, "VBW", (
        _num(wl, 2), _num(wt, 2), _status(wl, wt),
        _num(gl, 2), _num(gt, 2), _status(gl, gt),
        "", "V", "", "V"))


def vdr(view: BridgeView, talker: str) -> bytes:
    return sentence(talker, "VDR", (_bearing(view.get("stw", "current_set")), "T", "", "M",
                                    _num(_ratio(view.get("stw", "current"), KNOT, MAX_KNOTS), 2), "N"))


def hdt(view: BridgeView, talker: str) -> bytes:
    return sentence(talker, "HDT", (_bearing(view.get("manoeuvre", "heading")), "T"))


def rot(view: BridgeView, talker: str) -> bytes:
    rot = _ratio(view.get("manoeuvre", "r"), 1.0 / (_DEG * 60.0), MAX_ROT)
    return sentence(talker, "ROT", (_num(rot, 1), _status(rot)))


def xdr_name(mark: str) -> str:
    """`DRAFT_` and the initials of the mark's words: fore_port -> DRAFT_FP (letters
    and digits only, at most 8: a name never breaks the sentence's framing)."""
    initials = "".join(w[:1] for w in mark.split("_") if w).upper()
    return "DRAFT_" + "".join(c for c in initials if c.isascii() and c.isalnum())[:8]


def _xdr_readings(view: BridgeView) -> list[tuple[str, str, str, str]]:
    readings = [("D", _num(_metres(view.mark(m)), 2), "M", xdr_name(m)) for m in view.marks()]
    readings.append(("D", _num(_metres(view.get("draft", "mean_draft")), 2), "M", "DRAFT_MEAN"))
    readings.append(("D", _num(_metres(view.get("draft", "trim")), 2), "M", "TRIM"))
    readings.append(("D", _num(_metres(view.get("draft", "list")), 2), "M", "LIST"))
    return readings


def xdr(view: BridgeView, talker: str) -> bytes:
    """The readings in as few sentences as the length limit allows."""
    out: list[bytes] = []
    fields: list[str] = []
    for q in _xdr_readings(view):
        if fields and len(sentence(talker, "XDR", fields + list(q))) > MAX_SENTENCE:
            out.append(sentence(talker, "XDR", fields))
            fields = []
        fields.extend(q)
    out.append(sentence(talker, "XDR", fields))
    return b"".join(out)


#: The sentences, by type: the function that makes it from the view and the talker.
SENTENCES: dict[str, Callable[[BridgeView, str], bytes]] = {
    "VHW": vhw, "VBW": vbw, "VDR": vdr, "HDT": hdt, "ROT": rot, "XDR": xdr,
}
