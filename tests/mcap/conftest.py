"""Fixtures of the MCAP recorder tests: a recorder on a manual clock, sample records
(`mcap_rig`, shared with the analysis plugin's tests)."""

from __future__ import annotations

from typing import Any, Callable

import pytest
from mcap_rig import Rig, make_rig as _make_rig, sample_records


@pytest.fixture
def make_rig() -> Callable[..., Rig]:
    """A recorder built from config keys, on a manual clock at T0."""
    return _make_rig


@pytest.fixture
def records() -> list[Any]:
    return sample_records()


@pytest.fixture
def sample() -> Callable[..., list[Any]]:
    return sample_records


#: JSON types and what Python value each admits (for the structural schema checks).
_JSON_TYPES: dict[str, Callable[[Any], bool]] = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "number": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
}


def check_schema(schema: Any, where: str = "$") -> None:
    """Structural check that `schema` is a well-formed JSON Schema (the subset used)."""
    assert isinstance(schema, dict), where
    t = schema.get("type")
    if t is not None:
        types = t if isinstance(t, list) else [t]
        assert types and all(x in _JSON_TYPES for x in types), f"{where}: type {t!r}"
    props = schema.get("properties", {})
    assert isinstance(props, dict), where
    for k, sub in props.items():
        check_schema(sub, f"{where}.{k}")
    req = schema.get("required", [])
    assert isinstance(req, list) and len(set(req)) == len(req), where
    assert set(req) <= set(props), f"{where}: required {set(req) - set(props)} not in properties"
    if "items" in schema:
        check_schema(schema["items"], f"{where}[]")
    for bound in ("minimum", "maximum"):
        if bound in schema:
            assert _JSON_TYPES["number"](schema[bound]), where
    if "additionalProperties" in schema:
        assert isinstance(schema["additionalProperties"], bool), where


def conforms(value: Any, schema: dict[str, Any], where: str = "$") -> None:
    """Assert `value` satisfies `schema` (types, required, bounds, closed objects)."""
    t = schema.get("type")
    if t is not None:
        types = t if isinstance(t, list) else [t]
        assert any(_JSON_TYPES[x](value) for x in types), f"{where}: {value!r} is not {t}"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        assert value >= schema.get("minimum", value), where
        assert value <= schema.get("maximum", value), where
    if "enum" in schema:
        assert value in schema["enum"], where
    if isinstance(value, dict):
        props = schema.get("properties", {})
        for k in schema.get("required", []):
            assert k in value, f"{where}: missing {k}"
        if schema.get("additionalProperties") is False:
            assert set(value) <= set(props), f"{where}: extra {set(value) - set(props)}"
        for k, v in value.items():
            if k in props:
                conforms(v, props[k], f"{where}.{k}")
    if isinstance(value, list) and "items" in schema:
        assert len(value) >= schema.get("minItems", 0), where
        assert len(value) <= schema.get("maxItems", len(value)), where
        for i, v in enumerate(value):
            conforms(v, schema["items"], f"{where}[{i}]")


@pytest.fixture
def schema_checks() -> tuple[Callable[..., None], Callable[..., None]]:
    return check_schema, conforms
