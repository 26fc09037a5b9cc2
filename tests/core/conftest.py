"""Fixtures for the core tests: a registry holding only the dummy plugins."""

from __future__ import annotations

from pathlib import Path

import pytest
from core_dummies import ChainEstimator, DummyInput, DummyLog, FileOutput, ListOutput, MeanEstimator, SumEstimator

from edged.registry import Registry


@pytest.fixture
def registry() -> Registry:
    DummyInput.runs = 0
    SumEstimator.cores = []
    ListOutput.instances = []
    r = Registry(use_entry_points=False)
    r.register("inputs", "dummy", DummyInput)
    r.register("logs", "dummy", DummyLog())
    r.register("estimators", "sum", SumEstimator)
    r.register("estimators", "chain", ChainEstimator)
    r.register("estimators", "mean", MeanEstimator)
    r.register("outputs", "list", ListOutput)
    r.register("outputs", "file", FileOutput)
    return r


@pytest.fixture
def write_config(tmp_path: Path):
    def _write(text: str, name: str = "edged.toml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p

    return _write
