"""A real `edged replay --speed 1` publishing to a subscriber in another process."""

from __future__ import annotations

import json
import math
from functools import reduce

import pytest

from edged.registry import Registry

T0 = 1_732_350_000.0
N = 60  # 6 s of a 10 Hz gyro: time for a query and, under load, another


def _nmea(body: str) -> str:
    return f"${body}*{reduce(lambda a, ch: a ^ ord(ch), body, 0):02X}"


def _heading_deg(i: int) -> float:
    return (12.5 * i) % 360.0


def test_replay_publishes_measurements_answers_queries_and_holds_liveliness(tmp_path, free_port, zpeer, spawn):
    Registry().get("inputs", "nmea0183")  # first-party: PluginNotFound is a broken install, a failure
    log = tmp_path / "gyro.nmea"
    log.write_text("".join(f"{T0 + i * 0.1:.3f} {_nmea(f'HEHDT,{_heading_deg(i):.1f},T')}\n" for i in range(N)))
    peer_port, own_port = free_port(), free_port()
    zcfg = tmp_path / "replay.json5"
    zcfg.write_text(
        '{listen: {endpoints: ["tcp/127.0.0.1:%d"]}, connect: {endpoints: ["tcp/127.0.0.1:%d"]}}' % (own_port, peer_port)
    )
    # The subscriber listens first, so the replay's session finds it at open.
    peer = zpeer("--prefix", "vessel/rp1", "--listen", f"tcp/127.0.0.1:{peer_port}", "--no-wait-alive")
    peer.expect(lambda s: s == "ready")
    replay = spawn(
        peer.proc.args[0], "-m", "edged.cli", "replay", str(log), "--speed", "1", "--no-progress",
        "--vessel-id", "rp1", "--zenoh-config", str(zcfg),
    )
    assert peer.expect(lambda s: s.startswith("alive ")) == "alive put vessel/rp1/alive"
    first = json.loads(peer.expect(lambda s: s.startswith("sample vessel/rp1/meas/heading/gyro ")).split(" ", 3)[3])
    # Mid-voyage, the vessel's queryable answers with its latest heading. A get is best
    # effort: on a loaded machine one came back empty (its reply was counted sent by
    # the replay), so an empty answer is asked again while the voyage lasts.
    reply = None
    for _ in range(3):
        peer.send("get vessel/rp1/**")
        line = peer.expect(lambda s: s.startswith("reply vessel/rp1/meas/heading/gyro ") or s == "end")
        if line != "end":
            reply = line
            peer.expect(lambda s: s == "end")
            break
    assert reply is not None, "three queries mid-voyage, no answer with the heading"
    assert json.loads(reply.split(" ", 2)[2])["t"] >= first["t"]
    # Everything after the link came up arrives, the log's last record included ...
    t_last = round(T0 + (N - 1) * 0.1, 3)
    # ... and as the replay ends, its liveliness token goes with its session. The DELETE
    # travels at a higher priority than data and may overtake the last samples: wait
    # for both, in either order.
    last_line = f'"t":{t_last},'
    wanted = {"last": lambda s: s.startswith("sample vessel/rp1/meas/heading/gyro ") and last_line in s,
              "gone": lambda s: s == "alive delete vessel/rp1/alive"}
    while wanted:
        line = peer.expect(lambda s: any(p(s) for p in wanted.values()))
        wanted = {k: p for k, p in wanted.items() if not p(line)}
    assert replay.proc.wait(30) == 0

    got = [json.loads(s.split(" ", 3)[3]) for s in peer.seen if s.startswith("sample vessel/rp1/meas/heading/gyro ")]
    assert [g["t"] for g in got] == sorted(g["t"] for g in got)  # data time, in order
    assert all(g["source"] == "gyro" and set(g) == {"t", "t_src", "source", "heading"} for g in got)
    assert got[-1]["t"] == t_last
    assert got[-1]["heading"] == pytest.approx(math.radians(_heading_deg(N - 1)), abs=1e-9)
    assert len(got) >= N // 2
