"""The Foxglove layout of `deploy/foxglove-layout.json`, made with Foxglove's own
layout types (`foxglove.layouts`), so that its format is the one the app reads.

One layout for the live server (`[outputs.foxglove]`) and for recordings: both have
the same channels. It names the channels of the example configuration
(`deploy/edged.toml`: GNSS `gnss1`, Doppler log `doppler`, estimators `stw`,
`manoeuvre`, `draft`); a test checks that every topic and field it names is one the
recorder and this output make for that configuration, so it cannot rot.

The map shows the GNSS fix (`/location/gnss1`, a LocationFix the recording has) and
the manoeuvring estimate's position: a user script in the layout turns
`/est/manoeuvre` (lat, lon) into a LocationFix on `ESTIMATE_LOCATION`, in the browser,
for live data and recordings alike.

    python -m edged_foxglove.layout > deploy/foxglove-layout.json
"""

from __future__ import annotations

import json
import sys

import foxglove.layouts as fl
from edged.estimates import ESTIMATE_KINDS

__all__ = ["ESTIMATE_LOCATION", "build", "layout_json"]

GNSS = "/location/gnss1"
#: The user script's output: the manoeuvring estimate's position as a LocationFix.
ESTIMATE_LOCATION = "/foxglove_script/est_manoeuvre_location"

_SCRIPT = f"""// The manoeuvring estimate's position as a foxglove.LocationFix, for the Map panel.
// Written by edged (plugins/edged_foxglove/layout.py); a stale estimate is not shown.
import {{ Input }} from "./types.ts";
import {{ LocationFix }} from "@foxglove/schemas";

export const inputs = ["/est/manoeuvre"];
export const output = "{ESTIMATE_LOCATION}";

type Estimate = {{ t?: number; lat?: number | null; lon?: number | null; stale?: boolean }};

export default function script(event: Input<"/est/manoeuvre">): LocationFix | undefined {{
  const m = event.message as unknown as Estimate;
  if (typeof m.lat !== "number" || typeof m.lon !== "number" || m.stale === true) {{
    return undefined;
  }}
  const t = typeof m.t === "number" ? m.t : 0;
  const sec = Math.floor(t);
  return {{
    timestamp: {{ sec, nsec: Math.round((t - sec) * 1e9) }},
    frame_id: "manoeuvre",
    latitude: m.lat,
    longitude: m.lon,
    altitude: 0,
    position_covariance: [0, 0, 0, 0, 0, 0, 0, 0, 0],
    position_covariance_type: 0,
  }} as LocationFix;
}}
"""


def _series(value: str, label: str, *, right: bool = False) -> fl.PlotSeries:
    return fl.PlotSeries(value=value, label=label, enabled=True, use_right_y_axis=right or None)


def _plot(title: str, series: list[fl.PlotSeries], y_label: str) -> fl.PlotPanel:
    return fl.PlotPanel(
        title=title,
        config=fl.PlotConfig(paths=series, show_legend=True, legend_display="top", y_axis_label=y_label,
                             x_axis_val="timestamp", time_window_mode="automatic"),
    )


def _map() -> fl.MapPanel:
    return fl.MapPanel(
        title="Position: GNSS and estimate",
        config=fl.MapConfig(
            follow_topic=GNSS,
            layer="map",
            zoom_level=14,
            topic_colors={GNSS: "#1f77b4", ESTIMATE_LOCATION: "#d62728"},
        ),
    )


def _speeds() -> fl.PlotPanel:
    return _plot("STW: estimate, log, SOG", [
        _series("/est/stw.stw", "STW estimate"),
        _series("/meas/water_speed/doppler.stw_long", "Doppler log (along)"),
        _series("/est/stw.sog", "SOG (filtered)"),
        _series("/meas/velocity_ground/gnss1.sog", "SOG (GNSS)"),
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


def build() -> fl.Layout:
    """The layout: the map left; speeds, manoeuvre and drafts stacked right; health."""
    right = fl.SplitContainer(direction="column", items=[
        fl.SplitItem(content=_speeds()),
        fl.SplitItem(content=_manoeuvre()),
        fl.SplitItem(content=_drafts()),
    ])
    left = fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=2, content=_map()),
        fl.SplitItem(proportion=1, content=_health()),
    ])
    return fl.Layout(
        content=fl.SplitContainer(direction="row", items=[
            fl.SplitItem(proportion=2, content=left),
            fl.SplitItem(proportion=3, content=right),
        ]),
        user_scripts={"edged_estimate_location": fl.UserScript(name="edged: estimate on the map",
                                                               source_code=_SCRIPT)},
    )


def layout_json() -> str:
    """The layout file's text: indented, keys in the SDK's order, a final newline."""
    return json.dumps(json.loads(build().to_json()), indent=2, ensure_ascii=False) + "\n"


if __name__ == "__main__":
    sys.stdout.write(layout_json())
