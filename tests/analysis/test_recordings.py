"""Reading a recording through the core's `edged.recordings`: how `score` and `plot`
read a file without importing the plugin of its format (issue 33).

The MCAP reader (`edged_mcap.recordings`, entry point `edged.recordings: mcap`) is the
one installed; the choice among several, and the refusal of a file none reads, are
tested with readers registered by hand.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator

import pytest
from mcap_rig import T0, write_recording

from edged.records import Estimate, Measurement
from edged.recordings import (
    RecordedMessage,
    RecordingError,
    RecordingReport,
    every_topic,
    recording_reader,
)
from edged.registry import Registry
from mcap_rig import foreign_mcap
from edged_mcap.recordings import RECORDINGS


def test_the_installed_mcap_reader_is_found_and_gives_topic_schema_time_and_payload(tmp_path):
    path = write_recording(tmp_path / "r.mcap", [
        Estimate("stw", "stw", T0, {"stw": 5.0}, kind="stw"),
        Measurement("water_speed", "log1", T0 + 1, {"stw_long": 5.2}),
    ])
    reader = recording_reader(path, Registry())
    assert reader is RECORDINGS
    report = RecordingReport()
    got = list(reader.messages(path, report, lambda t: t.startswith(("/est/", "/meas/"))))
    assert [(m.topic, m.log_time) for m in got] == [("/est/stw", int(T0 * 1e9)), ("/meas/water_speed/log1", int((T0 + 1) * 1e9))]
    assert got[0].schema == "edged.est.stw" and got[0].payload["stw"] == 5.0 and got[0].payload["kind"] == "stw"
    assert got[1].payload["stw_long"] == 5.2
    assert report == RecordingReport(finished=True)


def test_payloads_are_decoded_as_the_standard_library_decodes_them(tmp_path):
    huge = b"1" + b"0" * 400  # JSON, but beyond any float: orjson refuses it
    path = foreign_mcap(tmp_path / "f.mcap", [
        ("/a", b'{"x": 1.5, "n": [1, 2]}'),
        ("/a", b'{"x": NaN}'),  # the standard library's JSON, not RFC 8259's
        ("/a", b'{"x": %s}' % huge),
        ("/a", b"not json"),
        ("/a", b"[" * 100_000 + b"]" * 100_000),  # nested beyond any payload's depth
        ("/skipped", b"not json either"),  # not wanted: not decoded, not counted
    ])
    report = RecordingReport()
    got = [m.payload for m in RECORDINGS.messages(path, report, lambda t: t == "/a")]
    assert got[0] == {"x": 1.5, "n": [1, 2]} == json.loads(b'{"x": 1.5, "n": [1, 2]}')
    assert got[1]["x"] != got[1]["x"]  # NaN
    assert got[2] == {"x": int(huge)}
    assert len(got) == 3 and report.undecodable == 2


def test_an_unfinished_recording_reads_as_far_as_it_goes_and_says_why(tmp_path):
    path = write_recording(tmp_path / "r.mcap", [Estimate("stw", "stw", T0 + i * 0.1, {"stw": 5.0}, kind="stw")
                                                 for i in range(3000)], chunk_kib=4, compression="none")
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    report = RecordingReport()
    n = sum(1 for _ in RECORDINGS.messages(cut, report))
    assert 0 < n < 3000
    assert not report.finished and report.unfinished_why == "ends inside a record"


def test_a_file_that_is_no_recording_is_refused_by_the_only_reader_in_its_words(tmp_path):
    bad = tmp_path / "bad.mcap"
    bad.write_text("hello")
    reader = recording_reader(bad, Registry())  # no reader knows it: the only one says why
    with pytest.raises(RecordingError, match="not a valid MCAP file"):
        list(reader.messages(bad, RecordingReport()))


@dataclass(frozen=True)
class _Lines:
    """A reader of text files of `topic,json` lines (a format of its own, for the test)."""

    name: str = "lines"

    def sniff(self, head: bytes) -> bool:
        return head.startswith(b"#lines")

    def messages(
        self, path: Path, report: RecordingReport, wanted: Callable[[str], bool] = every_topic
    ) -> Iterator[RecordedMessage]:
        for i, line in enumerate(path.read_text().splitlines()[1:]):
            topic, _, data = line.partition(",")
            if wanted(topic):
                yield RecordedMessage(topic, None, i, json.loads(data))


def _registry(**readers: Any) -> Registry:
    reg = Registry(use_entry_points=False)
    for name, reader in readers.items():
        reg.register("recordings", name, reader)
    return reg


def test_with_several_readers_the_one_that_knows_the_file_reads_it(tmp_path):
    text = tmp_path / "r.lines"
    text.write_text('#lines\n/est/x,{"t": 1.0}\n')
    mcap = write_recording(tmp_path / "r.mcap", [Estimate("stw", "stw", T0, {"stw": 5.0}, kind="stw")])
    reg = _registry(lines=_Lines(), mcap=RECORDINGS)
    assert isinstance(recording_reader(text, reg), _Lines)
    assert recording_reader(mcap, reg) is RECORDINGS
    other = tmp_path / "other.bin"
    other.write_bytes(b"\x00\x01")
    with pytest.raises(RecordingError, match=r"not a recording any installed reader reads \(readers: lines, mcap\)"):
        recording_reader(other, reg)
    with pytest.raises(RecordingError, match="none installed"):
        recording_reader(other, _registry())
