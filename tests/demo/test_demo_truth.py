"""The demo's truth.csv: the scenario's truth on the clock the live vessel played it on."""

from __future__ import annotations

import numpy as np

from edged.clock import ManualClock
from edged_demo.truth import OriginClock, TruthWriter
from edged_sim.run import Simulation
from edged_sim.scenarios import SCENARIOS
from edged_sim.truth import columns


def _read(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def test_truth_is_the_scenarios_moved_to_the_vessels_start_and_cut_where_it_stopped(tmp_path):
    clock = ManualClock(1_800_000_000.0)
    origin = OriginClock(clock)
    writer = TruthWriter(tmp_path / "truth.csv", "demo", 0, origin)
    writer.advance(clock.now() + 5)
    assert writer.rows == 0 and not (tmp_path / "truth.csv").exists()  # the vessel has not started
    start = origin.now()  # what LiveVessel.run reads first
    writer.advance(start + 2.5)
    assert writer.rows == 20  # two whole seconds at 10 Hz
    assert writer.finish(start + 3.25) == tmp_path / "truth.csv"
    assert writer.played == 3.25

    header, rows = _read(tmp_path / "truth.csv")
    assert header == list(columns())
    t, t_rel = rows[:, header.index("t")], rows[:, header.index("t_rel")]
    assert np.allclose(t_rel, np.arange(33) / 10.0) and np.allclose(t, start + t_rel, atol=1e-3)

    sim = Simulation(SCENARIOS["demo"], 0, duration=4.0)
    want = np.concatenate([sim.advance(s + 1.0).truth["lat"] for s in range(4)])[:33]
    assert np.allclose(rows[:, header.index("lat")], want, atol=1e-9)

    writer.rename(tmp_path / "edged-x.truth.csv")
    assert writer.path.exists() and not (tmp_path / "truth.csv").exists()


def test_no_truth_file_when_the_vessel_never_started(tmp_path):
    writer = TruthWriter(tmp_path / "truth.csv", "demo", 0, OriginClock(ManualClock(1.0)))
    assert writer.finish(100.0) is None and writer.rows == 0
    assert not (tmp_path / "truth.csv").exists()


def test_the_printed_commands_can_be_pasted_however_edged_was_run():
    import sys

    from edged_demo.command import _as_run

    assert _as_run("/opt/edged/venv/bin/edged") == "/opt/edged/venv/bin/edged"
    assert _as_run("edged") == "edged"
    assert _as_run("/work/edged/cli.py") == f"{sys.executable} -m edged.cli"
