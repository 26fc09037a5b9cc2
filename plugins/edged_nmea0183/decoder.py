"""Raw NMEA 0183 records -> canonical measurements (the `Decoder` of edged.plugin).

Works from a RawRecord alone (`data` = the sentence, `t` = its time), so that a replay
of an MCAP recording decodes exactly as the live input did. The record was checked
(checksum policy, framing) when it was received; the decoder does not check again.

Counters (in the health it was made with):
- `sentences.<TYPE>`: sentences of a type it decodes (TYPE without talker: GGA, HDT…);
- `invalid.<TYPE>`: of those, ones that gave no measurement because the sentence said
  its data is invalid, a needed field was empty, or a value was impossible;
- `invalid.RMC.variation`: RMCs whose magnetic variation was malformed or outside
  ±180° (the fix is kept; the variation in use stays the last good or configured one);
- `measurements.<kind>`: measurements emitted;
- `unknown.<TYPE>`: sentences of other types (kept raw only); at most MAX_UNKNOWN_KEYS
  distinct types are named, the rest count as `unknown.other`;
- `encapsulated.<TYPE>`: `!` sentences (AIS VDM/VDO), recorded raw, not decoded;
- `malformed`: records that are not a sentence at all (no address field);
- `rejected.own_output`: sentences with the talker ID of one of edged's own NMEA 0183
  outputs (a loop: edged never reads its own estimates back as measurements).
"""

from __future__ import annotations

from typing import Any

from edged.health import ComponentHealth
from edged.plugin import NO_MARKS, OwnMarks
from edged.records import KINDS, InvalidMeasurement, Measurement, RawRecord, validate_measurement

from .handlers import HANDLERS, Env, Handler, Invalid
from .reporting import ProblemReporter
from .sentences import sentence_class
from .timeofday import nearest_time

MAX_UNKNOWN_KEYS = 64
#: The mark (`OutputPlugin.own_marks`) of the talker IDs edged's NMEA 0183 outputs send.
OWN_TALKER = "nmea0183.talker"
_KIND_KEYS = {k: "measurements." + k for k in KINDS}


class DecoderSettings:
    """The parts of the input's configuration the decoder uses."""

    __slots__ = ("variation", "vbw_ground", "own_talkers")

    def __init__(self, variation: float | None = None, vbw_ground: bool = False,
                 own_talkers: frozenset[str] = frozenset()) -> None:
        self.variation = variation
        self.vbw_ground = vbw_ground
        #: The talker IDs edged's own NMEA 0183 outputs send (`own_output`).
        self.own_talkers = own_talkers

    @classmethod
    def from_config(cls, config: Any, own: OwnMarks = NO_MARKS) -> "DecoderSettings":
        talkers = frozenset(own.get(OWN_TALKER, frozenset()))
        if config is None:
            return cls(own_talkers=talkers)
        return cls(getattr(config, "variation", None), bool(getattr(config, "vbw_ground", False)), talkers)


class _Type:
    """Per sentence type: its handler, pre-built counter keys and field count.

    `width` is the number of fields the standard gives the type (with the address):
    a sentence from an older talker with fewer fields is padded with empty ones, so
    handlers index fields directly and read a missing field as an empty one.
    """

    __slots__ = ("handler", "sentences", "invalid", "width")

    def __init__(self, stype: str, handler: Handler) -> None:
        self.handler = handler
        self.sentences = "sentences." + stype
        self.invalid = "invalid." + stype
        self.width = len(sentence_class(stype).fields) + 1


class Nmea0183Decoder:
    __slots__ = ("source", "_health", "_settings", "_env", "_types", "_unknown", "_reporter", "_own")

    def __init__(self, source: str, health: ComponentHealth, settings: DecoderSettings | None = None) -> None:
        self.source = source
        self._health = health
        self._settings = settings or DecoderSettings()
        self._env = Env(self._settings.variation, self._settings.vbw_ground)
        self._types = {k: _Type(k, h) for k, h in HANDLERS.items()}
        self._unknown: dict[str, str] = {}
        self._reporter = ProblemReporter(health)
        self._own = self._settings.own_talkers

    def decode(self, raw: RawRecord) -> list[Measurement]:
        try:
            return self._decode(raw)
        except Exception as exc:  # a decoder bug must not stop the input (DESIGN §8)
            self._health.count("decode_errors")
            self._reporter.report(f"decoder failure: {type(exc).__name__}: {exc}")
            return []

    def _decode(self, raw: RawRecord) -> list[Measurement]:
        data = raw.data
        if data[:1] == b"\\":  # a TAG block left in front (records from other writers)
            data = data[data.find(b"\\", 1) + 1 :]
        text = data.decode("ascii", "replace")
        star = text.find("*")
        f = (text[1:star] if star > 0 else text[1:]).split(",")
        addr = f[0]
        if addr[:2] in self._own:
            self._health.count("rejected.own_output")
            return []
        entry = self._types.get(addr[2:]) if len(addr) == 5 and text[0] == "$" and addr[0] != "P" else None
        if entry is None:
            self._count_other(text, addr)
            return []
        counters = self._health.counters  # direct increments: this runs per sentence
        counters[entry.sentences] = counters.get(entry.sentences, 0) + 1
        short = entry.width - len(f)
        if short > 0:
            f += [""] * short
        try:
            items, tod, variation = entry.handler(f, self._env)
        except (Invalid, ValueError, IndexError) as exc:
            self._invalid(entry, exc if isinstance(exc, Invalid) else "empty or malformed field")
            return []
        if variation is not None:
            if -180.0 <= variation <= 180.0:  # false for NaN too
                self._env.variation = variation  # RMC's variation outranks the configured one
            else:
                self._bad_variation(entry, variation)
        t = raw.t
        t_src = None if tod is None else nearest_time(t, tod)
        result: list[Measurement] = []
        for kind, values in items:
            try:
                validate_measurement(kind, values)
            except InvalidMeasurement as exc:
                self._invalid(entry, f"{str(exc).split('=')[0].split(' ')[0]} impossible")
                continue
            key = _KIND_KEYS[kind]
            counters[key] = counters.get(key, 0) + 1
            result.append(Measurement(kind, self.source, t, values, t_src))
        return result

    def _bad_variation(self, entry: _Type, variation: float) -> None:
        """A variation that cannot be true is rejected by itself: the sentence's fix is
        kept, and so is the variation later magnetic sentences use (the last good one,
        else the configured one)."""
        key = entry.invalid + ".variation"
        self._health.count(key)
        # One message whatever the value: logged once, not once per sentence.
        self._reporter.report(
            f"{key}: magnetic variation malformed or outside ±180° rejected; "
            "the last good (or configured) variation stays in use"
        )

    def _invalid(self, entry: _Type, why: object) -> None:
        self._health.count(entry.invalid)
        self._reporter.report(f"{entry.invalid}: {why}")

    def _count_other(self, text: str, addr: str) -> None:
        """Sentences not decoded: unknown types, proprietary, encapsulated, garbage."""
        health = self._health
        if len(addr) == 5 and addr.isalnum() and text[:1] == "!":
            health.count("encapsulated." + addr[2:] if addr[2:].isalpha() else "encapsulated.other")
        elif text[:1] == "$" and addr[:1] == "P" and len(addr) >= 2 and addr.isalnum():
            health.count(self._unknown_key(addr))  # proprietary: $PASHR, $PFEC
        elif len(addr) == 5 and addr.isalnum() and text[:1] == "$":
            health.count(self._unknown_key(addr[2:]))
        else:
            health.count("malformed")

    def _unknown_key(self, stype: str) -> str:
        key = self._unknown.get(stype)
        if key is None:
            if len(self._unknown) >= MAX_UNKNOWN_KEYS:
                return "unknown.other"  # bounded: garbage must not grow the counters
            key = self._unknown[stype] = "unknown." + stype
        return key
