"""`edged demo` publishes all three estimates over Zenoh and, without a terminal, prints
plain status lines (no dashboard, no terminal control codes) and how to look at,
score and plot what it recorded.

A zenoh session of the test listens on 127.0.0.1 and the demo's publisher connects to
it (`--zenoh-config`); nothing leaves loopback, multicast scouting is off.
"""

from __future__ import annotations

import io
import json
import socket
import threading

from edged.cli import build_parser
from edged.registry import Registry
from edged_demo.command import main

import zenoh  # noqa: E402  (a dependency: its absence is a failure)

VESSEL = "demotest"
ESTIMATES = ("stw", "manoeuvre", "draft")


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _session(listen: str) -> "zenoh.Session":
    cfg = zenoh.Config()
    cfg.insert_json5("mode", '"peer"')
    cfg.insert_json5("listen/endpoints", json.dumps([listen]))
    cfg.insert_json5("connect/endpoints", "[]")
    cfg.insert_json5("scouting/multicast/enabled", "false")
    cfg.insert_json5("scouting/gossip/enabled", "false")
    return zenoh.open(cfg)


def test_the_demo_publishes_every_estimate_over_zenoh_and_prints_plain_lines(tmp_path):
    Registry().get("outputs", "zenoh")  # first-party: not installed is a failure
    ours, theirs = _port(), _port()
    zcfg = tmp_path / "demo.json5"
    zcfg.write_text(
        '{listen: {endpoints: ["tcp/127.0.0.1:%d"]}, connect: {endpoints: ["tcp/127.0.0.1:%d"]}}' % (theirs, ours)
    )
    got: dict[str, list[dict]] = {}
    lock = threading.Lock()
    all_seen = threading.Event()

    def on_sample(s: "zenoh.Sample") -> None:
        with lock:
            got.setdefault(str(s.key_expr), []).append(json.loads(s.payload.to_bytes()))
            if all(f"vessel/{VESSEL}/est/{e}" in got for e in ESTIMATES):
                all_seen.set()

    session = _session(f"tcp/127.0.0.1:{ours}")
    try:
        sub = session.declare_subscriber(f"vessel/{VESSEL}/est/*", on_sample)
        args = build_parser().parse_args(
            ["demo", "--duration", "6", "--record-dir", str(tmp_path / "rec"), "--vessel-id", VESSEL,
             "--zenoh-config", str(zcfg), "--foxglove-port", "0"]
        )
        out = io.StringIO()
        assert main(args, out=out) == 0
        # A safety net only: the samples were sent while the demo ran.
        assert all_seen.wait(10), f"estimates seen over zenoh: {sorted(got)}"
        sub.undeclare()
    finally:
        session.close()
    with lock:
        for e in ESTIMATES:
            samples = got[f"vessel/{VESSEL}/est/{e}"]
            assert all(s["kind"] == e for s in samples), samples[:2]
        assert any(s["stw"] is not None for s in got[f"vessel/{VESSEL}/est/stw"])

    text = out.getvalue()
    assert "\x1b[" not in text and "Sources" not in text  # no dashboard without a terminal
    status = [line for line in text.splitlines() if line.startswith("demo: ")]
    assert status and all(" measurements, " in line and " estimates; outputs: " in line for line in status), text
    assert f"vessel/{VESSEL}/** on this machine only" in text
    recording = sorted((tmp_path / "rec").glob("edged-*.mcap"))
    truth = sorted((tmp_path / "rec").glob("edged-*.truth.csv"))
    assert len(recording) == 1 and len(truth) == 1, text
    assert truth[0].name == recording[0].stem + ".truth.csv"
    assert f"inspect {recording[0]}" in text
    assert f"score {recording[0]} --truth {truth[0]}" in text
    assert f"plot {recording[0]} --truth {truth[0]} -o demo.png" in text
    assert len(truth[0].read_text().splitlines()) > 50  # header and ~10 rows a second
