"""`edged plot` on recordings, through the real CLI: the panels a recording has data
for, and the data behind them (`edged_analysis.plotdata`). The `plot` extra
(matplotlib) is part of the test environment: without it these tests fail."""

from __future__ import annotations

from pathlib import Path

import pytest

from edged.cli import main as cli
from edged.records import Estimate, Measurement
from mcap_rig import voyage_with_a_log_gap


@pytest.fixture
def recording(tmp_path) -> Path:
    return voyage_with_a_log_gap(tmp_path / "voyage.mcap")


def test_plot_draws_the_panels_that_have_data(recording, tmp_path, capsys):
    out = tmp_path / "report.png"
    assert cli(["plot", str(recording), "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    err = capsys.readouterr().err
    for panel in ("track", "speed", "motion", "rate", "draft", "trim"):
        assert panel in err


def test_plot_without_plottable_data_fails_clearly(make_rig, tmp_path, capsys):
    path = tmp_path / "h.mcap"
    rig = make_rig(path=str(path))
    rig.open()
    rig.close()
    assert cli(["plot", str(path), "-o", str(tmp_path / "r.png")]) == 1
    assert "nothing to plot" in capsys.readouterr().err


def test_plot_without_matplotlib_names_the_extra(recording, tmp_path, capsys, monkeypatch):
    from edged_analysis.commands import plot

    monkeypatch.setattr(plot, "_have_matplotlib", lambda: False)
    assert cli(["plot", str(recording), "-o", str(tmp_path / "r.png")]) == 1
    assert "pip install 'edged[plot]'" in capsys.readouterr().err


def test_plot_data_uses_raw_drafts_without_an_estimate_and_a_local_metric_track(make_rig, tmp_path):
    from edged_analysis.plotdata import collect, local_xy

    path = tmp_path / "d.mcap"
    rig = make_rig(path=str(path))
    rig.open()
    rig.rec.write([Measurement("draft", "can0.DraftMark", 10.0 + i, {"mark": "fore_port", "draft": 7.5, "status": 0}) for i in range(3)])
    rig.close()
    data = collect(path)
    assert list(data.panel("draft")) == ["fore_port"]
    xs, ys = local_xy([60.0, 60.001], [23.0, 23.002], 60.0, 23.0)
    assert ys[1] == pytest.approx(111.2, abs=0.1)  # 0.001° of latitude
    assert xs[1] == pytest.approx(2 * 111.2 * 0.5, abs=0.1)  # cos 60° = 0.5


def test_plot_data_has_the_marks_each_draft_estimate_left_out(make_rig, tmp_path):
    """Issue 31: the draft panel shows the mean draft, trim, list and which marks were out."""
    from edged_analysis.plotdata import MARK_ORDER, collect

    path = tmp_path / "o.mcap"
    rig = make_rig(path=str(path))
    rig.open()
    marks = {m: {"draft": 7.0, "mean": 7.0, "ok": True} for m in MARK_ORDER}
    ests = []
    for i in range(4):
        out = {**marks, "mid_port": {**marks["mid_port"], "ok": i < 2}}
        ests.append(Estimate("draft", "draft", 10.0 + i, {"marks": out, "mean_draft": 7.0, "trim": 0.1, "list": 0.0}))
    rig.rec.write(ests)
    rig.close()
    data = collect(path)
    out = data.panel("marks_out")
    assert list(out) == ["mid_port"] and out["mid_port"].t == [12.0, 13.0]
    assert out["mid_port"].y == [MARK_ORDER.index("mid_port") + 1] * 2
    assert {"mean draft", "mid_port"} <= set(data.panel("draft")) and set(data.panel("trim")) == {
        "trim (+ by the stern)", "list (port - stbd)"}


def test_plot_draws_the_marks_out_panel(make_rig, tmp_path, capsys):
    from edged_analysis.plotdata import MARK_ORDER

    path = tmp_path / "o.mcap"
    rig = make_rig(path=str(path))
    rig.open()
    marks = {m: {"draft": 7.0, "mean": 7.0, "ok": m != "aft_stbd"} for m in MARK_ORDER}
    rig.rec.write([Estimate("draft", "draft", 10.0 + i, {"marks": marks, "mean_draft": 7.0, "trim": 0.1, "list": 0.0})
                   for i in range(3)])
    rig.close()
    assert cli(["plot", str(path), "-o", str(tmp_path / "r.png")]) == 0
    assert "marks out" in capsys.readouterr().err
