"""pynmea2 sentence definitions used by the decoder, plus THS which pynmea2 lacks.

The decoder addresses fields by the names pynmea2 gives them (resolved to indices once,
here) rather than through pynmea2's typed attributes: those convert through Decimal
and cost about half the input stage's budget (docs/DEPENDENCIES.md). pynmea2 remains
the reference for each sentence's layout, and the tests check decoded values against
its typed attributes.
"""

from __future__ import annotations

from decimal import Decimal

import pynmea2
from pynmea2 import TalkerSentence

if "THS" in TalkerSentence.sentence_types:  # a later pynmea2 may ship its own
    THS = TalkerSentence.sentence_types["THS"]
else:

    class THS(TalkerSentence):  # type: ignore[no-redef]
        """True heading and status (IEC 61162-1): `$--THS,x.x,a*hh`.

        Subclassing registers it with pynmea2 (its metaclass keys sentence types by
        class name), so `pynmea2.parse` reads THS too.
        """

        fields = (
            ("Heading", "heading", Decimal),
            ("Mode indicator", "mode"),  # A autonomous, E estimated, M manual, S simulator, V invalid
        )


def sentence_class(stype: str) -> type[TalkerSentence]:
    return TalkerSentence.sentence_types[stype]


def field_index(stype: str, *names: str) -> tuple[int, ...]:
    """Positions of pynmea2's named fields in `line.split(',')` (index 0 is the address)."""
    idx = sentence_class(stype).name_to_idx
    return tuple(idx[n] + 1 for n in names)


__all__ = ["THS", "field_index", "sentence_class", "pynmea2"]
