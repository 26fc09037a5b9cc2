"""`edged demo` runs the simulated vessel through the daemon's real inputs and outputs."""

from __future__ import annotations

import io
import json
import socket

from mcap.reader import make_reader

from edged.cli import build_parser
from edged_demo.command import main


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_demo_reads_both_inputs_and_records(tmp_path):
    # 6 s: the manoeuvre filter starts from 3 s of fixes (its init_window), and a 3-s
    # demo on a loaded machine could end before its first estimate.
    port = _free_port()
    args = build_parser().parse_args(
        ["demo", "--duration", "6", "--no-zenoh", "--record-dir", str(tmp_path / "rec"), "--foxglove-port", str(port)]
    )
    out = io.StringIO()
    assert main(args, out=out) == 0
    text = out.getvalue()
    assert "recording:" in text and str(tmp_path / "rec") in text
    assert f"foxglove:   ws://127.0.0.1:{port} live" in text
    files = sorted((tmp_path / "rec").glob("edged-*.mcap"))
    assert files, text
    topics: dict[str, int] = {}
    with open(files[-1], "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            topics[channel.topic] = topics.get(channel.topic, 0) + 1
            if channel.topic == "/health":
                health = json.loads(message.data)
    # NMEA over UDP and N2K/DBC over virtual CAN both reached the recorder.
    assert any(t.startswith("/raw/nmea0183/nmea") for t in topics), topics
    assert any(t.startswith("/raw/can/") for t in topics), topics
    assert any(t.startswith("/meas/heading/") for t in topics), topics
    assert any(t.startswith("/meas/position/") for t in topics), topics
    assert set(health["inputs"]) == {"nmea", "can0"}
    fox = health["outputs"]["foxglove"]  # the live Foxglove view served all along
    assert fox["ok"] and fox["info"]["url"] == f"ws://127.0.0.1:{port}", fox
    # every estimator has its inputs: the draft marks too
    assert any(t.startswith("/meas/draft/") for t in topics), topics
    assert {"/est/stw", "/est/manoeuvre", "/est/draft"} <= set(topics), topics


def test_the_demo_has_a_mean_draft_trim_and_list_from_its_fifth_second(tmp_path):
    """Issue 31: the marks' rhythm was taken from the first frames' 0.1–1.8 ms, every
    mark was out for `gaps` for ~20 s, and a 30-s demo published no mean draft."""
    args = build_parser().parse_args(
        ["demo", "--duration", "10", "--no-zenoh", "--record-dir", str(tmp_path / "rec"), "--foxglove-port", "0"]
    )
    assert main(args, out=io.StringIO()) == 0
    files = sorted((tmp_path / "rec").glob("edged-*.mcap"))
    drafts, first = [], None
    with open(files[-1], "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            first = message.log_time if first is None else min(first, message.log_time)
            if channel.topic == "/est/draft":
                drafts.append((message.log_time, json.loads(message.data)))
    late = [d for at, d in drafts if (at - first) / 1e9 >= 5.0]
    assert late, f"{len(drafts)} draft estimates, none after the fifth second"
    for d in late:
        assert d["mean_draft"] is not None and d["trim"] is not None and d["list"] is not None, d
