"""Hardening, second round (issue 32), the command line: a flag a user mistypes gets
one line that names it and says what it takes, never a traceback or a link."""

from __future__ import annotations

from pathlib import Path

import pytest
from nmea_text import sentence

from edged.cli import build_parser, main


def _parse_exit(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(argv)
    return int(e.value.code), capsys.readouterr().err


@pytest.mark.parametrize("seed", ["-1", "-4294967296", "4294967296", "99999999999999999999", "1.5", "one", ""])
def test_a_seed_numpy_cannot_take_is_refused_at_parsing(seed, capsys):
    code, err = _parse_exit(["sim", "draft-harbour", "--out", "x", f"--seed={seed}"], capsys)
    assert code == 2
    assert "--seed" in err and "0 to 4294967295" in err and "Traceback" not in err


@pytest.mark.parametrize("seed", ["0", "7", "4294967295"])
def test_seeds_in_range_pass(seed):
    assert build_parser().parse_args(["sim", "draft-harbour", "--out", "x", "--seed", seed]).seed == int(seed)


@pytest.mark.parametrize("vid", ["a/b", "a b", "*", "ä", "a$b", ""])
def test_a_vessel_id_that_is_no_key_segment_says_why(vid, tmp_path: Path, capsys):
    log = tmp_path / "a.log"
    log.write_text("")
    rc = main(["replay", "--no-zenoh", "--no-progress", "--vessel-id", vid, str(log)])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "--vessel-id" in err and "Zenoh key segment" in err
    assert "pydantic" not in err and "http" not in err


def _nmea_log(path: Path, seconds: int) -> Path:
    path.write_text("".join(sentence(f"GPGGA,1200{k:02d}.00,5400.000,N,01000.000,E,1,08,0.9,5.0,M,40.0,M,,") + "\n"
                            for k in range(seconds)))
    return path


@pytest.mark.parametrize("others", [["meta.json"], ["meta.json", "truth.csv", "draft.toml"]])
def test_files_that_are_no_log_are_named_and_skipped(others, tmp_path: Path, capsys):
    """`edged replay DIR/*` after `edged sim --out DIR`: the logs replay, exit 0, and
    each other file is named on stderr."""
    log = _nmea_log(tmp_path / "nmea.log", 5)
    rest = []
    for name in others:
        (tmp_path / name).write_text('{"scenario": "x"}\n' if name.endswith(".json") else "t,x\n1,2\n")
        rest.append(str(tmp_path / name))
    rc = main(["replay", "--no-zenoh", "--no-progress", str(log), *rest])
    out = capsys.readouterr()
    assert rc == 0, out.err
    for name in others:
        assert f"skipped {tmp_path / name}: format not recognised" in out.err
    assert "replayed 5 records" in out.out


@pytest.mark.parametrize("n", [1, 3])
def test_nothing_left_to_replay_is_bad_usage(n, tmp_path: Path, capsys):
    files = []
    for k in range(n):
        f = tmp_path / f"notes{k}.txt"
        f.write_text("nothing a reader knows\n")
        files.append(str(f))
    assert main(["replay", "--no-zenoh", "--no-progress", *files]) == 2
    err = capsys.readouterr().err
    assert f"none of the {n} file(s) is a log" in err and all(f"skipped {f}" in err for f in files)


@pytest.mark.parametrize("target", ["/proc/version", "/proc/edged-test.mcap", "/sys/kernel/edged-test.mcap"])
def test_recording_onto_a_kernel_filesystem_is_bad_usage_naming_it(target, tmp_path: Path, capsys):
    """Was "disk_low" and exit 1 after the replay: it is a usage error, told first."""
    log = _nmea_log(tmp_path / "nmea.log", 3)
    assert main(["replay", "--no-zenoh", "--no-progress", "--record", target, str(log)]) == 2
    err = capsys.readouterr().err
    assert f"--record {target}: is on a filesystem without storage" in err


@pytest.mark.parametrize("command", ["run", "replay"])
@pytest.mark.parametrize("size", [4, 1 << 20])
def test_a_zenoh_config_that_is_no_text_is_refused_before_anything_starts(command, size, tmp_path: Path, capsys):
    """Was: `run --zenoh-config` with a binary file ran on silently where no zenoh
    plugin read it."""
    junk = tmp_path / "z.json5"
    junk.write_bytes((b"\x00\x01\xff\xfe" * (size // 4 + 1))[:size])
    cfg = tmp_path / "edged.toml"
    cfg.write_text('[inputs.nmea]\ntype = "nmea0183"\ntransport = "udp"\nport = 47999\n')
    log = _nmea_log(tmp_path / "nmea.log", 3)
    argv = ["run", "-c", str(cfg)] if command == "run" else ["replay", "--no-progress", str(log)]
    assert main([*argv, "--zenoh-config", str(junk)]) == 2
    err = capsys.readouterr().err
    assert f"{junk}: --zenoh-config: not a json5 text file" in err


@pytest.mark.parametrize("zenoh_out", [False, True])
def test_run_says_when_a_zenoh_config_is_given_that_no_plugin_reads(zenoh_out, tmp_path: Path, monkeypatch, capsys):
    """A good file given where no zenoh input or output is configured: not silent."""
    import edged.runcmd as runcmd

    async def stopped_at_once(rt, *a, **k):
        return 0

    monkeypatch.setattr(runcmd, "run_daemon", stopped_at_once)
    z = tmp_path / "z.json5"
    z.write_text('{ mode: "client" }\n')
    cfg = tmp_path / "edged.toml"
    text = '[inputs.nmea]\ntype = "nmea0183"\ntransport = "udp"\nport = 47999\n'
    if zenoh_out:
        text += '[outputs.zenoh]\ntype = "zenoh"\n'
    cfg.write_text(text)
    assert main(["run", "-c", str(cfg), "--zenoh-config", str(z)]) == 0
    said = "event=option-unused option=--zenoh-config" in capsys.readouterr().err
    assert said is not zenoh_out
