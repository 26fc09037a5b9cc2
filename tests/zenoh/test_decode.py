"""ZenohDecoder: payloads to measurements, every rejection counted, replay self-describing."""

from __future__ import annotations

import logging
import math

import pytest

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.records import Measurement, RawRecord
from edged_zenoh.decode import ZenohDecoder
from edged_zenoh.input import ZenohInput, ZenohInputConfig

T = 1_732_350_000.0
KEY = "vessel/v1/env/current"


def _health() -> ComponentHealth:
    return ComponentHealth("shore", "input", "zenoh", ManualClock(T))


def _raw(payload: bytes, key: str = KEY, **meta) -> RawRecord:
    return RawRecord("zenoh", "shore", T, payload, {"key": key, **meta})


def test_current_forecast_becomes_a_current_measurement():
    dec = ZenohDecoder(_health())
    (m,) = dec.decode(_raw(b'{"t": 1732349000.5, "set": 1.25, "drift": 0.8}'))
    assert m == Measurement("current", "shore", T, {"set": 1.25, "drift": 0.8}, t_src=1732349000.5)


def test_directions_in_minus_pi_to_pi_are_wrapped():
    (m,) = ZenohDecoder(_health()).decode(_raw(b'{"t": 1, "set": -1.5707963267948966, "drift": 0.5}'))
    assert m.values["set"] == pytest.approx(1.5 * math.pi)


@pytest.mark.parametrize("v", [b"1e300", b"-4.0", b"6.3"])
def test_directions_beyond_minus_pi_to_two_pi_are_rejected_not_wrapped(v):
    h = _health()
    assert ZenohDecoder(h).decode(_raw(b'{"set": ' + v + b', "drift": 0.5}')) == []
    assert h.counters["rejected.invalid"] == 1


def test_a_direction_of_two_pi_is_north():
    (m,) = ZenohDecoder(_health()).decode(_raw(b'{"set": 6.283185307179586, "drift": 0.5}'))
    assert m.values["set"] == 0.0


def test_envelope_of_a_republished_measurement_is_ignored():
    payload = b'{"t": 5.0, "t_src": 4.0, "source": "ashore-model", "set": 0.1, "drift": 0.2}'
    (m,) = ZenohDecoder(_health()).decode(_raw(payload))
    assert m.values == {"set": 0.1, "drift": 0.2} and m.t_src == 5.0 and m.source == "shore"


def test_time_is_optional():
    (m,) = ZenohDecoder(_health()).decode(_raw(b'{"set": 0.1, "drift": 0.2}'))
    assert m.t_src is None and m.t == T


@pytest.mark.parametrize(
    ("payload", "reason"),
    [
        (b"\xff\xfe", "not_json"),
        (b'{"t": 1, "set": 0.1', "not_json"),
        (b"[1, 2]", "not_object"),
        (b'"current"', "not_object"),
        (b'{"t": "yesterday", "set": 0.1, "drift": 0.2}', "bad_time"),
        (b'{"t": true, "set": 0.1, "drift": 0.2}', "bad_time"),
        (b'{"t": NaN, "set": 0.1, "drift": 0.2}', "bad_time"),
        (b'{"t": 1, "set": 0.1}', "invalid"),  # drift missing
        (b'{"t": 1, "set": 0.1, "drift": -0.2}', "invalid"),  # a speed cannot be negative
        (b'{"t": 1, "set": NaN, "drift": 0.2}', "invalid"),
        (b'{"t": 1, "set": "north", "drift": "fast"}', "invalid"),
        (b'{"t": 1, "set": 0.1, "drift": 0.2, "dir": 3}', "invalid"),  # unknown field
    ],
)
def test_bad_payloads_are_counted_and_rejected(payload, reason):
    h = _health()
    assert ZenohDecoder(h).decode(_raw(payload)) == []
    assert h.counters == {f"rejected.{reason}": 1, "errors": 1}
    assert h.last_error == f"{KEY}: rejected ({reason})"


def test_unmapped_key_is_rejected():
    h = _health()
    assert ZenohDecoder(h).decode(_raw(b'{"depth": 3}', key="elsewhere/depth")) == []
    assert h.counters["rejected.unknown_key"] == 1


def test_a_stream_of_bad_payloads_logs_once(caplog):
    h = _health()
    dec = ZenohDecoder(h)
    with caplog.at_level(logging.WARNING, logger="edged.health"):
        for i in range(50):
            dec.decode(_raw(b'{"t": 1, "set": 0.1, "drift": -%d}' % (i + 1)))
    assert h.counters["rejected.invalid"] == 50
    assert len([r for r in caplog.records if "rejected" in r.getMessage()]) == 1
    assert "drift" in h.info["last_rejected"]


def test_mapped_keys_decode_by_configuration_or_by_recorded_kind():
    config = ZenohInputConfig.model_validate(
        {"type": "zenoh", "subscriptions": [{"key": "ship/echo", "kind": "depth", "source": "echo"}]}
    )
    h = _health()
    dec = ZenohInput.make_decoder("shore", config, h)
    (m,) = dec.decode(RawRecord("zenoh", "echo", T, b'{"depth": 12.5, "offset": -0.5}', {"key": "ship/echo"}))
    assert (m.kind, m.source, m.values) == ("depth", "echo", {"depth": 12.5, "offset": -0.5})
    # A replay without any configuration: the record says which kind it is.
    bare = ZenohInput.make_decoder("echo", None, h)
    rec = RawRecord("zenoh", "echo", T, b'{"depth": 12.5}', {"key": "some/echo/*", "kind": "depth"})
    assert [x.kind for x in bare.decode(rec)] == ["depth"]
    # ... and a recorded forecast replays from its key alone.
    (c,) = bare.decode(_raw(b'{"t": 1, "set": 0.5, "drift": 0.4}', key="vessel/other/env/current"))
    assert c.kind == "current"


def test_configuration_errors_name_the_key():
    from pydantic import ValidationError

    with pytest.raises(ValidationError, match="unknown measurement kind 'wind'"):
        ZenohInputConfig.model_validate({"type": "zenoh", "subscriptions": [{"key": "a", "kind": "wind", "source": "s"}]})
    with pytest.raises(ValidationError, match="source"):
        ZenohInputConfig.model_validate({"type": "zenoh", "subscriptions": [{"key": "a", "kind": "depth", "source": "a/b"}]})
