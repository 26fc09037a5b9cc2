"""`edged replay --record` with the recorder in a process of its own (the default) records
what the recorder in the event loop records: the same messages, log and publish times."""

from __future__ import annotations

import collections
from pathlib import Path

import pytest
from mcap.reader import make_reader

import edged.replaycmd as replaycmd
from edged.cli import build_parser
from edged.commands import dispatch
from edged.registry import Registry

PARTICULARS = ('[estimators.stw]\ntype = "stw"\n[estimators.draft]\ntype = "draft"\nmark_spacing = 225.0\nbeam = 32.2\n'
               'block_coefficient = 0.85\ntransducer_x = 67.5\ntransducer_height = 0.0\nworker = "loop"\n')


def _messages(path: Path) -> dict[str, list[tuple[int, int, bytes]]]:
    out: dict[str, list[tuple[int, int, bytes]]] = collections.defaultdict(list)
    with path.open("rb") as f:
        for _, channel, m in make_reader(f).iter_messages(log_time_order=False):
            out[channel.topic].append((m.log_time, m.publish_time, bytes(m.data)))
    return out


@pytest.fixture(scope="module")
def harbour(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("sim")
    args = build_parser().parse_args(["sim", "draft-harbour", "--out", str(d), "--seed", "3", "--duration", "20"])
    assert dispatch(args, Registry()) == 0
    return d


def _replay(harbour: Path, tmp_path: Path, name: str) -> Path:
    cfg = tmp_path / "replay.toml"
    cfg.write_text(PARTICULARS)
    out = tmp_path / f"{name}.mcap"
    args = build_parser().parse_args(["replay", str(harbour / "nmea.log"), str(harbour / "can.log"), "-c", str(cfg),
                                      "--no-zenoh", "--no-progress", "--record", str(out)])
    assert dispatch(args, Registry()) == 0
    return out


def test_the_recorder_in_its_process_records_what_it_records_in_the_loop(harbour, tmp_path, monkeypatch, capsys):
    in_process = _messages(_replay(harbour, tmp_path, "process"))
    out, err = capsys.readouterr()
    assert "messages recorded, 0 dropped, 0 rejected" in out
    assert "output-not-ready" not in err  # the replay began once the recorder was up

    plain = replaycmd.replay_config

    def in_the_loop(cfg, args, registry):
        cfg = plain(cfg, args, registry)
        assert cfg.outputs["record"].worker == "process"  # the default
        cfg.outputs["record"] = cfg.outputs["record"].model_copy(update={"worker": "loop"})
        return cfg

    monkeypatch.setattr(replaycmd, "replay_config", in_the_loop)
    in_loop = _messages(_replay(harbour, tmp_path, "loop"))
    assert set(in_process) == set(in_loop)
    assert sum(len(v) for v in in_loop.values()) > 15_000
    for topic in in_loop:
        if topic == "/health":  # (its counters say where the recorder ran and how it was batched)
            assert len(in_process[topic]) == len(in_loop[topic])
        elif topic.startswith("/est/"):
            # the same estimates; each written when its worker handed it over, which
            # depends on how the event loop ran the workers, wherever the recorder is
            assert [(t, d) for t, _, d in in_process[topic]] == [(t, d) for t, _, d in in_loop[topic]], topic
        else:  # raw data and measurements: the same bytes, times and publish times
            assert in_process[topic] == in_loop[topic], topic


def test_a_recorder_whose_process_is_killed_goes_on_in_a_numbered_file(tmp_path):
    import asyncio
    import os
    import signal

    from edged.clock import ManualClock
    from edged.config import parse_config
    from edged.records import Measurement
    from edged.runtime import Runtime
    from edged.supervisor import RestartPolicy

    async def no_wait(delay: float) -> None:
        await asyncio.sleep(0)

    async def wait_for(cond) -> None:
        loop = asyncio.get_running_loop()
        end = loop.time() + 60.0
        while not cond():
            assert loop.time() < end, "condition not reached"
            await asyncio.sleep(0.001)

    registry = Registry()
    out = tmp_path / "voyage.mcap"
    cfg = parse_config({"outputs": {"rec": {"type": "mcap", "path": str(out), "fsync": False}}}, registry)
    clock = ManualClock(1_732_350_000.0)
    rt = Runtime(cfg, registry, clock, restart=RestartPolicy(initial=0.01), sleep=no_wait)

    async def main():
        await rt.start()
        host = rt.outputs[0]
        await wait_for(lambda: host.up)
        first = host.plugin.pid
        for i in range(100):
            rt.router.publish(Measurement("heading", "gyro", clock.now() + i * 0.1, {"heading": 1.0}))
        rt.tick()  # the chunk goes to the file
        await wait_for(lambda: host.health.counters.get("recorded", 0) >= 100)
        os.kill(first, signal.SIGKILL)
        await wait_for(lambda: host.health.restarts >= 1 and host.up and host.plugin.pid not in (None, first))
        for i in range(100, 150):
            rt.router.publish(Measurement("heading", "gyro", clock.now() + i * 0.1, {"heading": 1.0}))
        await rt.stop()
        return list(host.plugin.files), host.health.last_error

    files, error = asyncio.run(main())
    assert files == [out, tmp_path / "voyage.001.mcap"]
    assert "process" in error
    second = _messages(files[1])
    assert len(second["/meas/heading/gyro"]) == 50  # the first file was left as it was: not overwritten
    assert out.stat().st_size > 0
