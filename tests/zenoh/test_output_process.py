"""The Zenoh output as another process sees it: keys, payloads, queries, liveliness."""

from __future__ import annotations

import asyncio
import json
import math

import pytest

from edged.records import Estimate, HealthRecord, Measurement, RawRecord
from edged_zenoh.output import ZenohOutput, ZenohOutputConfig

T0 = 1_732_350_000.0


def _parse(line: str) -> tuple[str, str, dict]:
    _, key, encoding, payload = line.split(" ", 3)
    return key, encoding, json.loads(payload)


def _output(make_ctx, port: int, vessel: str = "v1", **cfg) -> ZenohOutput:
    c = make_ctx("zenoh", vessel)
    config = ZenohOutputConfig.model_validate({"type": "zenoh", "listen": [f"tcp/127.0.0.1:{port}"], **cfg})
    return ZenohOutput(config, c.ctx)


def test_subscriber_process_receives_keys_and_payloads(make_ctx, free_port, zpeer):
    port = free_port()

    async def scenario() -> None:
        out = _output(make_ctx, port)
        await out.open()
        await asyncio.wait_for(out.connected.wait(), 30)
        # A first value, so the peer's readiness query has something to be answered with.
        out.write([Measurement("heading", "gyro", T0, {"heading": 0.5})])
        peer = zpeer("--prefix", "vessel/v1", "--connect", f"tcp/127.0.0.1:{port}")
        assert peer.expect(lambda s: s.startswith("alive ")) == "alive put vessel/v1/alive"
        peer.expect(lambda s: s == "ready")

        out.write(
            [
                RawRecord("nmea0183", "gyro", T0 + 0.1, b"$HEHDT,28.6,T*1C"),
                Measurement("heading", "gyro", T0 + 0.2, {"heading": 0.6}, t_src=T0 + 0.19),
                Measurement("position", "gnss1", T0 + 0.2, {"lat": 60.1, "lon": 24.9, "fix_quality": 1}),
                Estimate("stw", "stw", T0 + 0.2, {"stw": 5.1, "stw_std": 0.1, "dvl_stw": None}, kind="stw"),
                Estimate("some_future_estimator", "x", T0 + 0.2, {"a": [1, 2], "b": {"c": math.nan}}),
                HealthRecord(T0 + 0.3, {"t": T0 + 0.3, "outputs": {"zenoh": {"state": "running"}}}),
            ]
        )
        got = {}
        while len(got) < 5:
            key, enc, obj = _parse(peer.expect(lambda s: s.startswith("sample ")))
            assert enc == "application/json"
            got[key] = obj
        assert got == {
            "vessel/v1/meas/heading/gyro": {"t": T0 + 0.2, "t_src": T0 + 0.19, "source": "gyro", "heading": 0.6},
            "vessel/v1/meas/position/gnss1": {
                "t": T0 + 0.2, "t_src": None, "source": "gnss1", "lat": 60.1, "lon": 24.9, "fix_quality": 1
            },
            "vessel/v1/est/stw": {
                "t": T0 + 0.2, "kind": "stw", "stale": False, "age": 0.0, "converging": False, "stw": 5.1, "stw_std": 0.1, "dvl_stw": None
            },
            # Any estimate name is published as it appears; NaN (no JSON form) as null.
            "vessel/v1/est/some_future_estimator": {
                "t": T0 + 0.2, "kind": None, "stale": False, "age": 0.0, "converging": False, "a": [1, 2], "b": {"c": None}
            },
            "vessel/v1/health": {"t": T0 + 0.3, "outputs": {"zenoh": {"state": "running"}}},
        }

        # The queryable answers with the latest value of each key the selector covers.
        out.write([Measurement("heading", "gyro", T0 + 0.25, {"heading": 0.7})])  # rate-limited: not published
        peer.send("get vessel/v1/**")
        replies = {}
        while (line := peer.expect(lambda s: s.startswith(("reply ", "end")))) != "end":
            _, key, payload = line.split(" ", 2)
            replies[key] = json.loads(payload)
        assert set(replies) == set(got)
        assert replies["vessel/v1/meas/heading/gyro"]["heading"] == 0.7
        assert replies["vessel/v1/est/stw"] == got["vessel/v1/est/stw"]

        peer.send("get vessel/v1/est/*")
        est = []
        while (line := peer.expect(lambda s: s.startswith(("reply ", "end")))) != "end":
            est.append(line.split(" ", 2)[1])
        assert sorted(est) == ["vessel/v1/est/some_future_estimator", "vessel/v1/est/stw"]

        # Raw records never left the process; liveliness ends with the session.
        assert not any("raw" in s or "nmea0183" in s for s in peer.seen)
        await out.close()
        assert peer.expect(lambda s: s.startswith("alive ")) == "alive delete vessel/v1/alive"

    asyncio.run(scenario())


def test_measurements_are_rate_limited_per_kind_on_data_time(make_ctx, free_port, zpeer):
    port = free_port()

    async def scenario() -> None:
        out = _output(make_ctx, port, meas_max_hz={"draft": 2.0, "yaw_rate": 0.0})
        await out.open()
        await asyncio.wait_for(out.connected.wait(), 30)
        peer = zpeer("--prefix", "vessel/v1", "--connect", f"tcp/127.0.0.1:{port}")
        peer.expect(lambda s: s == "ready")
        batch = []
        for i in range(100):  # one second of a 100 Hz draft mark and a 100 Hz rate gyro
            t = T0 + i * 0.01
            batch.append(Measurement("draft", "can0.DraftMark", t, {"mark": "fore_port", "draft": 7.0, "status": 0}))
            batch.append(Measurement("yaw_rate", "imu", t, {"r": 0.01}))
            batch.append(Measurement("heading", "gyro", t, {"heading": 1.0}))
        batch.append(Estimate("end", "x", T0 + 1.0, {}))
        out.write(batch)
        peer.expect(lambda s: s.startswith("sample vessel/v1/est/end"))
        samples = [s.split(" ", 3) for s in peer.seen if s.startswith("sample ")]
        draft_t = [json.loads(p)["t"] for _, k, _, p in samples if "/meas/draft/" in k]
        heading_t = [json.loads(p)["t"] for _, k, _, p in samples if "/meas/heading/" in k]
        # 2 Hz on data time: slots every 0.5 s, a record up to 5 % of a period early
        # takes its slot (jitter), the slot still moves on by one period.
        assert draft_t == pytest.approx([T0, T0 + 0.48, T0 + 0.98], abs=1e-6)
        assert heading_t == pytest.approx([T0 + 0.1 * i for i in range(10)], abs=1e-6)  # the 10 Hz default
        assert not any("/meas/yaw_rate/" in k for _, k, _, _ in samples)  # 0 Hz: off
        assert out.ctx.health.counters["rate_limited"] == 97 + 90
        await out.close()

    asyncio.run(scenario())
