"""Two logs replayed together come out in the order heapq.merge gives them."""

from __future__ import annotations

import heapq
import math
import random

from edged.records import RawRecord
from edged.timemerge import merge2 as _merge2, _t


def recs(name: str, times: list[float]) -> list[RawRecord]:
    return [RawRecord("x", name, t, b"", None) for t in times]


def test_two_logs_merge_in_time_order_with_ties_to_the_first_as_heapq_merges_them():
    rng = random.Random(1)
    for _ in range(3000):
        # whole seconds make many ties; some files empty
        a = sorted(rng.randint(0, 5) + rng.random() * rng.randint(0, 1) for _ in range(rng.randint(0, 8)))
        b = sorted(rng.randint(0, 5) + rng.random() * rng.randint(0, 1) for _ in range(rng.randint(0, 8)))
        A, B = recs("a", a), recs("b", b)
        got = list(_merge2(iter(A), iter(B)))
        assert [id(r) for r in got] == [id(r) for r in heapq.merge(A, B, key=_t)]


def test_a_record_without_a_time_does_not_hold_back_the_rest_of_its_log():
    # (the replay refuses it; what matters is that the others keep their order)
    A = recs("a", [1.0, 2.0, 3.0, 4.0])
    B = recs("b", [1.5, math.nan, 2.5, 3.5])
    got = [(r.source, r.t) for r in _merge2(A, B)]
    assert [t for _, t in got if t == t] == [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]
    A = recs("a", [1.0, math.nan, 3.0])
    B = recs("b", [0.5, 2.0, 4.0])
    assert [t for _, t in ((r.source, r.t) for r in _merge2(A, B)) if t == t] == [0.5, 1.0, 2.0, 3.0, 4.0]
