"""Log readers (entry point group `edged.logs`): what a third party's reader gets from
`edged replay`, the order readers are sniffed in, and which input decodes their records."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any, BinaryIO, Iterator

import pytest
from core_dummies import DummyDecoder, DummyInput, DummyLog, ListOutput

from edged.cli import build_parser
from edged.clock import ReplayClock
from edged.commands import dispatch
from edged.config import parse_config
from edged.health import ComponentHealth
from edged.plugin import LogReader, ReplayOptions
from edged.records import Measurement, RawRecord
from edged.registry import Registry
from edged.logformats import UnknownFormat, detect, log_readers
from edged.replay import Replayer
from edged.runtime import Runtime


class TsvLog:
    """A third party's format: `<t>\\t<kind>\\t<field>=<value>` lines after a `TSV` line."""

    name = "tsv"
    protocol = "dummy"
    input = "dummy"
    priority = 50

    def __init__(self) -> None:
        self.opened: list[str] = []

    def sniff(self, head: bytes) -> bool:
        return head.startswith(b"TSV\n")

    def open(
        self, stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
    ) -> Iterator[RawRecord]:
        self.opened.append(source)
        for line in stream:
            if line == b"TSV\n":
                continue
            parts = line.rstrip(b"\n").split(b"\t")
            if len(parts) != 3:
                health.count("rejected.not_tsv")
                continue
            health.count("lines")
            yield RawRecord("dummy", source, float(parts[0]), b" ".join(parts))


class Claims:
    """A reader that claims every head (or raises in `sniff` when told to)."""

    protocol = "dummy"
    input = "dummy"

    def __init__(self, name: str, priority: int, raises: bool = False) -> None:
        self.name = name
        self.priority = priority
        self.raises = raises

    def sniff(self, head: bytes) -> bool:
        if self.raises:
            raise RuntimeError("sniff broke")
        return True

    def open(self, stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions) -> Iterator[RawRecord]:
        return iter(())


def _only(**readers: Any) -> Registry:
    r = Registry(use_entry_points=False)
    for name, reader in readers.items():
        r.register("logs", name, reader)
    return r


def _run(registry: Registry, *argv: str) -> int:
    return dispatch(build_parser().parse_args(list(argv)), registry)


@pytest.fixture
def tsv_file(tmp_path: Path) -> Path:
    p = tmp_path / "wind.tsv"
    p.write_text("TSV\n1.0\tyaw_rate\tr=1\n2.0\tyaw_rate\tr=2\nbroken line\n3.0\tyaw_rate\tr=4\n")
    return p


def test_the_readers_satisfy_the_protocol():
    assert isinstance(TsvLog(), LogReader) and isinstance(DummyLog(), LogReader)
    assert not isinstance(object(), LogReader)


def test_a_third_party_reader_registered_by_hand_is_sniffed_and_used_by_edged_replay(registry, tsv_file, write_config, capsys):
    tsv = TsvLog()
    registry.register("logs", "tsv", tsv)
    ListOutput.instances.clear()
    cfg = write_config('[outputs.rec]\ntype = "list"\n')
    assert _run(registry, "replay", str(tsv_file), "-c", str(cfg), "--no-zenoh", "--no-progress") == 0
    assert tsv.opened == ["wind"]
    meas = [r for r in ListOutput.instances[0].records if isinstance(r, Measurement)]
    assert [(m.source, m.t, m.values) for m in meas] == [("wind", 1.0, {"r": 1.0}), ("wind", 2.0, {"r": 2.0}), ("wind", 3.0, {"r": 4.0})]
    out = capsys.readouterr().out
    assert "replayed 3 records, 2.0 s of data" in out
    # the reader's counters and the decoder's, under the file's source
    assert "rejected.not_tsv" in out and "measurements.yaw_rate" in out


def test_a_reader_given_in_extra_is_listed_with_the_installed_ones(tmp_path):
    """Registry(extra=...) beside the entry points: the third party's reader takes its
    place by priority among edged's own (tsv, 50, between the CAN formats and NMEA 0183)."""
    reg = Registry(extra={"logs": {"tsv": TsvLog()}})
    names = [n for n, _ in log_readers(reg)]
    assert "tsv" in names
    if "nmea0183" in names and "candump" in names:
        assert names.index("candump") < names.index("tsv") < names.index("nmea0183")
    odd = tmp_path / "odd.bin"
    odd.write_bytes(b"\x00\x01 nothing anyone reads\n")
    with pytest.raises(UnknownFormat) as exc:
        detect(odd, reg)
    assert str(exc.value) == f"{odd}: format not recognised (readers: {', '.join(names)})"
    p = tmp_path / "x.tsv"
    p.write_bytes(b"TSV\n1.0\tyaw_rate\tr=1\n")
    assert detect(p, reg)[0] == "tsv"


def test_priority_decides_between_two_readers_that_claim_a_head(tmp_path):
    p = tmp_path / "f.log"
    p.write_bytes(b"anything\n")
    # lower priority first, whatever the names' order
    assert detect(p, _only(aaa=Claims("aaa", 60), zzz=Claims("zzz", 40)))[0] == "zzz"
    assert detect(p, _only(aaa=Claims("aaa", 40), zzz=Claims("zzz", 60)))[0] == "aaa"
    # a tie goes by name
    assert detect(p, _only(bbb=Claims("bbb", 40), aaa=Claims("aaa", 40)))[0] == "aaa"
    assert [n for n, _ in log_readers(_only(c=Claims("c", 5), b=Claims("b", 9), a=Claims("a", 9)))] == ["c", "a", "b"]


def test_a_sniff_that_raises_is_logged_and_does_not_decide_for_the_others(tmp_path, caplog):
    p = tmp_path / "f.log"
    p.write_bytes(b"anything\n")
    reg = _only(broken=Claims("broken", 1, raises=True), good=Claims("good", 2))
    with caplog.at_level(logging.WARNING, logger="edged.replay"):
        assert detect(p, reg)[0] == "good"
    assert "log reader broken: sniff failed on" in caplog.text and "sniff broke" in caplog.text


def test_a_priority_that_is_not_an_integer_is_sniffed_last(tmp_path, caplog):
    odd = Claims("odd", 0)
    odd.priority = "first"  # type: ignore[assignment]
    with caplog.at_level(logging.WARNING, logger="edged.replay"):
        assert [n for n, _ in log_readers(_only(odd=odd, late=Claims("late", 1000)))] == ["late", "odd"]
    assert "priority 'first' is not an integer" in caplog.text


def test_unknown_format_names_the_file_and_every_reader_in_sniff_order(tmp_path):
    p = tmp_path / "odd.bin"
    p.write_bytes(b"\x00\x01\x02")
    reg = _only(tsv=TsvLog(), dummy=DummyLog())
    with pytest.raises(UnknownFormat) as exc:
        detect(p, reg)
    assert str(exc.value) == f"{p}: format not recognised (readers: dummy, tsv)"
    with pytest.raises(UnknownFormat) as exc:
        detect(p, _only())
    assert str(exc.value) == f"{p}: format not recognised (readers: none installed)"


class OtherDecoder(DummyDecoder):
    """A second decoder of protocol `dummy`: measurement kinds prefixed `other_`."""

    def decode(self, raw: RawRecord) -> list[Measurement]:
        return [Measurement("other_" + m.kind, m.source, m.t, m.values) for m in super().decode(raw)]


class AnotherDummyInput(DummyInput):
    """An input of the same protocol as `dummy`, sorting before it by name."""

    @classmethod
    def make_decoder(cls, source: str, config: Any, health: ComponentHealth, own: Any = None) -> OtherDecoder:
        return OtherDecoder(source, health)


class AskedRegistry(Registry):
    """Records the inputs the replay asks for by name."""

    asked: list[str]

    def get(self, role: str, name: str) -> Any:
        if role == "inputs":
            self.asked.append(name)
        return super().get(role, name)


async def _replay(registry: Registry, paths: list[Path]) -> tuple[Runtime, list]:
    ListOutput.instances.clear()
    rt = Runtime(parse_config({"outputs": {"rec": {"type": "list"}}}, registry), registry, ReplayClock(), replay=True)
    rep = Replayer(rt, paths)
    await rt.start()
    try:
        await rep.run()
    finally:
        await rt.stop()
    return rt, ListOutput.instances[0].records


def _asked_registry(**readers: Any) -> AskedRegistry:
    r = AskedRegistry(use_entry_points=False)
    r.asked = []
    r.register("inputs", "another", AnotherDummyInput)  # same protocol, first by name
    r.register("inputs", "dummy", DummyInput)
    r.register("outputs", "list", ListOutput)
    for name, reader in readers.items():
        r.register("logs", name, reader)
    return r


async def test_the_decoder_is_the_input_the_reader_names_and_the_file_health_has_its_type(tsv_file):
    reg = _asked_registry(tsv=TsvLog())
    rt, recs = await _replay(reg, [tsv_file])
    kinds = {r.kind for r in recs if isinstance(r, Measurement)}
    assert kinds == {"yaw_rate"}  # DummyInput's decoder, not the first input of protocol "dummy"
    assert reg.asked == ["dummy"]  # that one input only
    h = rt.health.components["input:wind"]
    assert h.type == "dummy"  # the type of the input the reader names, as before
    assert h.counters["lines"] == 3 and h.counters["rejected.not_tsv"] == 1


class ManyProtocols(TsvLog):
    """A reader of files holding many protocols (as MCAP does): no input of its own."""

    name = "many"
    protocol = ""
    input = None


async def test_records_of_a_reader_without_an_input_go_to_the_inputs_by_protocol(tsv_file):
    reg = _asked_registry(many=ManyProtocols())
    rt, recs = await _replay(reg, [tsv_file])
    kinds = {r.kind for r in recs if isinstance(r, Measurement)}
    assert kinds == {"other_yaw_rate"}  # the first input (by name) whose protocol is "dummy"
    assert set(reg.asked) == {"another", "dummy"}  # here, and only here, every input is loaded
    assert rt.health.components["input:wind"].type == "many"  # the reader's name, as "mcap" was


async def test_a_reader_naming_an_input_that_is_not_installed_leaves_its_records_undecoded(tsv_file, caplog):
    class Orphan(TsvLog):
        input = "not_installed"

    reg = _asked_registry(tsv=Orphan())
    with caplog.at_level(logging.WARNING, logger="edged.replay"):
        _, recs = await _replay(reg, [tsv_file])
    assert not [r for r in recs if isinstance(r, Measurement)]
    assert len([r for r in recs if isinstance(r, RawRecord)]) == 3
    assert "input not_installed" in caplog.text
