"""Shared helpers of the simulator tests: perfect-sensor runs and a DBC to decode with."""

from __future__ import annotations


import cantools
import pytest

from edged_can.reference import reference_dbc_path



@pytest.fixture(scope="session")
def dbc_db() -> cantools.database.Database:
    """The reference DBC the CAN input ships (DESIGN §5)."""
    return cantools.database.load_file(str(reference_dbc_path()))
