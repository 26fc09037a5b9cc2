"""Several sources of one quantity on the real logs of ../shared/data (issue 30): boats
at their berth with two compasses that disagree and several GNSS receivers, fed to the
default core as a replay without a source priority feeds it (every source)."""

from __future__ import annotations

import logging
import re
import math

import numpy as np
import pytest
from manoeuvre_data import measurements
from manoeuvre_real import DATA, LOGS, available
from manoeuvre_stream import run

from edged_manoeuvre.config import ManoeuvreConfig
from edged_manoeuvre.core import ManoeuvreCore

KN = 1852.0 / 3600.0
FED = ("position", "heading", "yaw_rate", "accel_body", "velocity_ground")
#: The boats at their berth and the two compasses that disagree on each (INDEX.md).
BERTH = {
    "dirona": ("7", "105"),
    "susteranna": ("128", "15"),
    "susteranna2020": ("128", "23"),
    "can0-1": ("23", "128"),
}


def _feed(name: str):
    quiet = logging.getLogger("edged")
    saved = quiet.level
    quiet.setLevel(logging.CRITICAL)
    try:
        ms = [m for m in measurements([DATA / LOGS[name].path]) if m.kind in FED]
    finally:
        quiet.setLevel(saved)
    core = ManoeuvreCore(ManoeuvreConfig(type="manoeuvre"))
    # the worker host's grid, restarted after a hole in the log's time (can0-1's 0.43 s
    # stamped 13.9 days early)
    out = run(core, ms, bound=50)
    return ms, core, out


@pytest.mark.parametrize("name", sorted(BERTH))
def test_at_the_berth_two_compasses_are_never_averaged(name):
    if not available(name):
        pytest.skip(f"{name}: ../shared/data not here")
    ms, core, out = _feed(name)
    first, second = BERTH[name]
    h = core.health()
    said = [p for p in h["problems"] if p.startswith("heading: sources")]
    assert len(said) == 1, h["problems"]
    assert f".{first} and " in said[0] and said[0].split(" and ")[1].split(" ")[0].endswith(f".{second}")
    kept = said[0].split("; ")[1].split(" kept")[0]
    # the SOG of a boat lying still, from its first estimate on (GNSS <= 0.6 kn)
    sog = np.array([e.values["sog"] for e in out])
    assert len(sog) > 100 and sog.max() <= 1.5 * KN, sog.max() / KN
    # the heading is the kept compass's, within 1°, once the disagreement was found
    t_found = min(m.t for m in ms if m.kind == "heading" and m.source == kept) + 5.0
    kept_h = [(m.t, m.values["heading"]) for m in ms if m.kind == "heading" and m.source == kept and m.t > t_found]
    te = np.array([e.t for e in out])
    he = np.array([e.values["heading"] for e in out])
    diffs = []
    for t, hk in kept_h:
        i = np.searchsorted(te, t)
        if 0 < i < len(te):
            diffs.append(abs((he[i] - hk + math.pi) % (2 * math.pi) - math.pi))
    assert diffs and max(np.degrees(diffs)) <= 1.0, np.degrees(max(diffs))


def test_a_hull_moving_sideways_is_named_in_health():
    """Furuno's log: the heading stays at 143° while the track runs 213° at 5.9 m/s, a
    drift angle no hull has: the heading or the positions are wrong."""
    if not available("furuno"):
        pytest.skip("furuno: ../shared/data not here")
    _, core, out = _feed("furuno")
    side = [p for p in core.health()["problems"] if "sideways" in p]
    assert len(side) == 1 and re.search(r"drift angle 7[01]°", side[0]), core.health()["problems"]
