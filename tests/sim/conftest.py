"""Shared helpers of the simulator tests: perfect-sensor runs and a DBC to decode with."""

from __future__ import annotations

from pathlib import Path

import cantools
import pytest

from edged_sim.dbc import DBC_TEXT

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def dbc_db() -> cantools.database.Database:
    """The reference DBC when the CAN input has landed it, else DESIGN §5 as text."""
    path = REPO / "deploy" / "edged-sensors.dbc"
    if path.exists():
        return cantools.database.load_file(str(path))
    return cantools.database.load_string(DBC_TEXT, database_format="dbc")
