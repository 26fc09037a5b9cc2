"""The reference DBC shipped in this package and how its signals map to measurement kinds.

The package file is the single source of truth; `deploy/edged-sensors.dbc` is a copy a
test keeps identical, so that an installed edged finds the DBC without the repository.
"""

from __future__ import annotations

from importlib.resources import as_file, files
from pathlib import Path
from typing import Any

#: Draft marks of DESIGN §5, in frame id order 0x310..0x315.
MARKS = ("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd")

DBC_NAME = "edged-sensors.dbc"


def reference_dbc_path() -> Path:
    """Path of the reference DBC inside the installed package."""
    with as_file(files(__package__).joinpath("data", DBC_NAME)) as p:
        # The package is installed as plain files (never zipped), so the path outlives
        # the context manager.
        return Path(p)


def reference_signals() -> list[dict[str, Any]]:
    """Signal mappings for the reference DBC, in the form of the `signals` config key."""
    drafts = [
        {
            "message": f"DraftMark_{mark}",
            "kind": "draft",
            "fields": {"draft": "draft", "status": "status"},
            "mark": mark,
            "source": "{bus}.DraftMark",
            "counter": "counter",
        }
        for mark in MARKS
    ]
    return drafts + [
        {"message": "ImuAccel", "kind": "accel_body", "fields": {"ax": "ax", "ay": "ay", "az": "az"}},
        # roll_rate / pitch_rate have no measurement kind (DESIGN §2): not mapped.
        {"message": "ImuRate", "kind": "yaw_rate", "fields": {"r": "yaw_rate"}},
        {
            "message": "ImuAttitude",
            "kind": "attitude",
            "fields": {"roll": "roll", "pitch": "pitch", "heave": "heave"},
        },
    ]
