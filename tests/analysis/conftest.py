"""Fixtures of the analysis tests: recordings are written with the project's own
recorder (`mcap_rig`), as `edged score` and `edged plot` meet them."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Sequence

import pytest
from mcap_rig import Rig, make_rig as _make_rig, sample_records, write_recording


@pytest.fixture
def make_rig() -> Callable[..., Rig]:
    """A recorder built from config keys, on a manual clock at T0."""
    return _make_rig


@pytest.fixture
def sample() -> Callable[..., list[Any]]:
    return sample_records


@pytest.fixture
def mcap(tmp_path) -> Callable[..., Path]:
    """Write records into tmp_path/<name> with the recorder; return the path."""

    def write(records: Sequence[Any], name: str = "voyage.mcap", **cfg: Any) -> Path:
        return write_recording(tmp_path / name, records, **cfg)

    return write
