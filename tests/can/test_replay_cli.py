"""`edged replay` of candump logs: the per-PGN and per-frame counts in the summary table."""

from __future__ import annotations

import struct
from pathlib import Path

from edged.cli import main
from edged.registry import Registry

T0 = 1732350000.0


def _log(path: Path, lines: list[tuple[float, str, bytes]]) -> Path:
    path.write_text("".join(f"({t:.6f}) can0 {ident}#{data.hex().upper()}\n" for t, ident, data in lines))
    return path


def _rows(out: str) -> dict[tuple[str, str], int]:
    """(source, counter) -> count of the summary table (the source is printed once)."""
    rows: dict[tuple[str, str], int] = {}
    source = ""
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[2].isdigit():
            source = parts[0]
            rows[(source, parts[1])] = int(parts[2])
        elif len(parts) == 2 and parts[1].isdigit() and line.startswith(" "):
            rows[(source, parts[0])] = int(parts[1])
    return rows


def test_replay_of_two_candump_files_prints_per_pgn_and_per_frame_counts(tmp_path, build, capsys):
    heading = build.pgn_127250(1.0)
    gnss = build.fast_frames(build.pgn_129029(60.0, 24.0), seq=2)
    gnss_id = f"{build.n2k_id(129029, 20, prio=3):08X}"
    a = _log(tmp_path / "a.log", [
        (T0 + 0.00, "310", struct.pack("<HBB", 7000, 0, 1)),
        (T0 + 0.01, f"{build.n2k_id(127250, 28):08X}", heading),
        *[(T0 + 0.02 + 0.001 * i, gnss_id, f) for i, f in enumerate(gnss[:4])],
    ])
    b = _log(tmp_path / "b.log", [
        *[(T0 + 0.03 + 0.001 * i, gnss_id, f) for i, f in enumerate(gnss[4:])],
        (T0 + 0.04, "321", struct.pack("<ihh", 1000, 0, 0)),
        (T0 + 0.05, "310", struct.pack("<HBB", 7010, 1, 3)),
        (T0 + 0.06, f"{build.n2k_id(130306, 9):08X}", bytes(8)),
    ])
    rc = main(["replay", str(a), str(b), "--no-zenoh", "--no-progress"])
    out = capsys.readouterr().out
    assert rc == 0, out
    rows = _rows(out)
    expected = {
        "frames": 12, "frames.n2k": 9, "frames.dbc": 3, "pgn.127250": 1, "pgn.129029": 1,
        "unknown_pgn.130306": 1, "dbc.DraftMark_fore_port": 2, "dbc.ImuRate": 1, "dbc.lost": 1,
        "measurements.draft": 2, "measurements.heading": 1, "measurements.position": 1,
        "measurements.yaw_rate": 1,
    }
    for counter, n in expected.items():
        assert rows.get(("can0", counter)) == n, (counter, out)
    assert "can0.DraftMark" in out and "can0.20" in out


#: Real logs whose time steps back (issue 32): what the summary says of them (can0-1:
#: 431 frames stamped two weeks early mid-log; dirona: 61 s back once).
STEPS_BACK = {
    "canboat__samples__can0-1.pcap__DERIVED_candump-l.log":
        "time stepped back: can0 by 1197906.6 s at its record 974 (to 2022-11-16T15:15:24.000Z, "
        "after 2022-11-30T12:00:30.557Z); 431 of its records",
    "canboat__samples__dirona-actisense-serial.raw":
        "time stepped back: canboat__samples__dirona-actisense-serial by 60.9 s at its record 17828 "
        "(to 2016-02-28T19:56:59.000Z, after 2016-02-28T19:57:59.915Z); 1466 of its records",
}


def test_every_shared_n2k_log_replays_and_an_unknown_format_is_named(n2k_data, tmp_path, capsys):
    for path in sorted(n2k_data.iterdir()):
        rc = main(["replay", str(path), "--no-zenoh", "--no-progress"])
        out = capsys.readouterr()
        assert "Traceback" not in out.err, path.name
        if path.name in STEPS_BACK:
            assert STEPS_BACK[path.name] in out.out, (path.name, out.out[:600])
        assert rc == 0, (path.name, out.err[-500:])
    odd = tmp_path / "seatalk.log"
    odd.write_bytes(b"\x84\x06\x00\x00\x00\x00\x00\x00 not a log anyone writes\n" * 20)
    assert main(["replay", str(odd), "--no-zenoh", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "format not recognised" in err and "seatalk.log" in err


def test_raw_can_recorded_to_mcap_decodes_again_to_the_same_measurements(n2k_data, tmp_path, capsys):
    """The decoder works from the RawRecord alone: MCAP replay equals candump replay."""
    # first-party: an MCAP recorder that is not installed is a broken install, a failure
    assert "mcap" in Registry().names("outputs"), Registry().names("outputs")
    log = n2k_data / "canboat__samples__candumpSample3.txt"
    rec = tmp_path / "out.mcap"
    assert main(["replay", str(log), "--no-zenoh", "--no-progress", "--record", str(rec)]) == 0
    first = capsys.readouterr().out
    assert main(["replay", str(rec), "--no-zenoh", "--no-progress"]) == 0
    again = capsys.readouterr().out

    def table(out: str) -> list[str]:
        lines = out[out.index("measurements by source and kind:"):].splitlines()[1:]
        return [line for line in lines if line.startswith("  ")]

    assert len(table(first)) >= 7 and table(again) == table(first)
