"""The Foxglove layout of `deploy/foxglove-layout.json`, made with Foxglove's own
layout types (`foxglove.layouts`), so that its format is the one the app reads.

One layout for the live server (`[outputs.foxglove]`) and for recordings: both have
the same channels. It names the channels of the example configuration
(`deploy/edged.toml`: GNSS `gnss1`, Doppler log `doppler`, estimators `stw`,
`manoeuvre`, `draft`); a test checks that every topic and field it names is one the
recorder and this output make for that configuration, so it cannot rot.

The map shows the GNSS fix (`/location/gnss1`) and the manoeuvring estimate's
position with its 1-σ (`/location/est/manoeuvre`): both are LocationFix channels the
recording and the live server have.

    python -m edged_foxglove.layout > deploy/foxglove-layout.json
    python -m edged_foxglove.layout --gnss nmea --log nmea > demo-layout.json  # `edged demo`'s
"""

from __future__ import annotations

import argparse
import json
import sys

import foxglove.layouts as fl
from edged.estimates import ESTIMATE_KINDS

__all__ = ["ESTIMATE_LOCATION", "build", "layout_json"]

#: The sources the layout names by default: `deploy/edged.toml`'s GNSS and log.
GNSS_SOURCE, LOG_SOURCE = "gnss1", "doppler"
#: The manoeuvring estimate's position, a LocationFix with its 1-σ (edged.channels).
ESTIMATE_LOCATION = "/location/est/manoeuvre"



def _series(value: str, label: str, *, right: bool = False) -> fl.PlotSeries:
    return fl.PlotSeries(value=value, label=label, enabled=True, use_right_y_axis=right or None)


def _plot(title: str, series: list[fl.PlotSeries], y_label: str) -> fl.PlotPanel:
    return fl.PlotPanel(
        title=title,
        config=fl.PlotConfig(paths=series, show_legend=True, legend_display="top", y_axis_label=y_label,
                             x_axis_val="timestamp", time_window_mode="automatic"),
    )


def _map(gnss: str) -> fl.MapPanel:
    fix = f"/location/{gnss}"
    return fl.MapPanel(
        title="Position: GNSS and estimate",
        config=fl.MapConfig(
            follow_topic=fix,
            layer="map",
            zoom_level=14,
            topic_colors={fix: "#1f77b4", ESTIMATE_LOCATION: "#d62728"},
        ),
    )


def _speeds(gnss: str, log: str) -> fl.PlotPanel:
    return _plot("STW: estimate, log, SOG", [
        _series("/est/stw.stw", "STW estimate"),
        _series(f"/meas/water_speed/{log}.stw_long", "Doppler log (along)"),
        _series("/est/stw.sog", "SOG (filtered)"),
        _series(f"/meas/velocity_ground/{gnss}.sog", "SOG (GNSS)"),
    ], "m/s")


def _manoeuvre() -> fl.PlotPanel:
    return _plot("Manoeuvring state: u, v (m/s); heading (rad), r (rad/s) right", [
        _series("/est/manoeuvre.u", "u surge"),
        _series("/est/manoeuvre.v", "v sway"),
        _series("/est/manoeuvre.heading", "heading", right=True),
        _series("/est/manoeuvre.r", "r yaw rate", right=True),
    ], "m/s")


def _drafts() -> fl.PlotPanel:
    marks = [_series(f"/est/draft.marks.{m}.mean", m.replace("_", " ")) for m in ESTIMATE_KINDS["draft"].marks]
    return _plot("Drafts (m): marks' means, mean; trim, list right", [
        *marks,
        _series("/est/draft.mean_draft", "mean draft"),
        _series("/est/draft.trim", "trim", right=True),
        _series("/est/draft.list", "list", right=True),
    ], "m")


def _health() -> fl.RawMessagesPanel:
    return fl.RawMessagesPanel(title="Health", config=fl.RawMessagesConfig(topic_path="/health", expansion="none"))


def build(gnss: str = GNSS_SOURCE, log: str = LOG_SOURCE) -> fl.Layout:
    """The layout: the map left; speeds, manoeuvre and drafts stacked right; health.
    `gnss` and `log` are the sources of the GNSS fix and the Doppler log."""
    right = fl.SplitContainer(direction="column", items=[
        fl.SplitItem(content=_speeds(gnss, log)),
        fl.SplitItem(content=_manoeuvre()),
        fl.SplitItem(content=_drafts()),
    ])
    left = fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=2, content=_map(gnss)),
        fl.SplitItem(proportion=1, content=_health()),
    ])
    return fl.Layout(
        content=fl.SplitContainer(direction="row", items=[
            fl.SplitItem(proportion=2, content=left),
            fl.SplitItem(proportion=3, content=right),
        ]),
    )


def layout_json(gnss: str = GNSS_SOURCE, log: str = LOG_SOURCE) -> str:
    """The layout file's text: indented, keys in the SDK's order, a final newline."""
    return json.dumps(json.loads(build(gnss, log).to_json()), indent=2, ensure_ascii=False) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m edged_foxglove.layout", description="write edged's Foxglove layout")
    ap.add_argument("--gnss", default=GNSS_SOURCE, help=f"source of the GNSS fix (default {GNSS_SOURCE})")
    ap.add_argument("--log", default=LOG_SOURCE, help=f"source of the Doppler log (default {LOG_SOURCE})")
    a = ap.parse_args(argv)
    for name in (a.gnss, a.log):
        if not name or any(c in name for c in "/.\"\\ "):
            ap.error(f"{name!r} is not a source name (an input's, as in /meas/<kind>/<source>)")
    sys.stdout.write(layout_json(a.gnss, a.log))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
