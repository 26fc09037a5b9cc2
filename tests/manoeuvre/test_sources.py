"""The duplicate-sensor check's cost (`edged_manoeuvre.sources.SourceCopies`, issue 32).

`edged replay` names each file's source by its stem: a thousand small files of GGA are a
thousand position sources. The check compared each reading with every source ever
heard and kept a pair for each: 250 files took 3.5 s and 224 MB, 1,000 files 95 s and
1.7 GB. Now a reading meets only the sources speaking within FAILOVER s, at most
MAX_COMPARED of them, so the pairs and the work grow with the sources heard at once."""

from __future__ import annotations

import numpy as np
import pytest

from edged_manoeuvre.sources import FAILOVER, MAX_COMPARED, SourceCopies


def _diff(a, b):
    return a - b


def _sigma(_source):
    return np.array([1.0, 1.0])


@pytest.mark.parametrize("files", [10, 100, 1000])
def test_files_one_after_the_other_keep_a_pair_per_neighbour(files):
    """Each file: 5 fixes at 1 Hz, the next file starting where it ends."""
    c = SourceCopies()
    t = 0.0
    for f in range(files):
        for _ in range(5):
            c.muted("position", f"f{f}", t, np.array([0.0, 0.0]), _diff, _sigma)
            t += 1.0
    assert len(c._pairs) <= files  # was files·(files − 1)/2
    assert len(c._last["position"]) <= 1 + int(FAILOVER)


@pytest.mark.parametrize("sources", [20, 200])
def test_many_sources_at_once_are_compared_with_a_bounded_few(sources):
    c = SourceCopies()
    rng = np.random.default_rng(1)
    for k in range(5):
        for s in range(sources):
            c.muted("heading", f"s{s}", k + 0.001 * s, rng.normal(size=2), _diff, _sigma)
    assert len(c._pairs) <= sources * MAX_COMPARED


def test_a_copy_is_still_found_and_muted():
    """What the check is for, unchanged: a source repeating another's readings."""
    c = SourceCopies()
    rng = np.random.default_rng(2)
    muted = []
    for k in range(60):
        z = rng.normal(size=2) * 5.0
        c.muted("heading", "gyro", k * 1.0, z, _diff, _sigma)
        muted.append(c.muted("heading", "copy", k * 1.0 + 0.01, z + 1e-4, _diff, _sigma))
    assert c.duplicates() == ["heading: gyro = copy"]
    assert all(muted[-10:])
