"""edged's own log readers (entry point group `edged.logs`): every real log is detected
as the format it was before the readers became a registry, and loading the readers to
sniff a file imports no decoding stack."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from edged.registry import Registry
from edged.logformats import detect, log_readers

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "data"

#: Every file of ../shared/data -> the reader that reads it. Before the registry, the
#: `can` input read all of n2k/ (and within it candump, or the first of the formats
#: modules whose sniff said yes, as below) and `nmea0183` all of nmea0183/.
DETECTED = {
    "n2k/canboat__samples__can0-1.pcap__DERIVED_candump-l.log": "candump",
    "n2k/canboat__samples__candumpSample1.txt": "candump",
    "n2k/canboat__samples__candumpSample2.txt": "candump",
    "n2k/canboat__samples__candumpSample3.txt": "candump",
    "n2k/canboat__samples__dirona-actisense-serial.raw": "actisense_plain",
    "n2k/canboat__samples__furuno-fap7011c-autopilot-maneuvers.raw": "actisense_plain",
    "n2k/canboat__samples__ikonvert.log": "ikonvert",
    "n2k/canboat__samples__merrimac-ydwg-2020.raw": "ydwg_raw",
    "n2k/canboat__samples__susteranna-actisense-serial.raw": "actisense_plain",
    "n2k/canboat__samples__susteranna2020.raw": "actisense_plain",
    "n2k/signalk-server__samples__aava-n2k.data": "actisense_plain",
    "nmea0183/gpsd__test__daemon__bundg_zeus_9.log": "nmea0183",
    "nmea0183/gpsd__test__daemon__hemi.log": "nmea0183",
    "nmea0183/gpsd__test__daemon__humminbird-M37.log": "nmea0183",
    "nmea0183/gpsd__test__daemon__pypilot.log": "nmea0183",
    "nmea0183/gpsd__test__daemon__rst39.log": "nmea0183",
    "nmea0183/gpsd__test__daemon__saab-r4.log": "nmea0183",
    "nmea0183/gpsd__test__daemon__skytraq-PX1172RH_DS.log": "nmea0183",
    "nmea0183/gpsd__test__daemon__sounder.log": "nmea0183",
    "nmea0183/signalk-server__samples__gofree-merrimac.log": "nmea0183",
    "nmea0183/signalk-server__samples__n2kd-183-merrimac.log": "nmea0183",
    "nmea0183/signalk-server__samples__plaka.log": "nmea0183",
}
#: The file's health component type (`edged replay`'s health records): the input's.
HEALTH_TYPE = {"candump": "can", "actisense_plain": "can", "ydwg_raw": "can", "ikonvert": "can", "nmea0183": "nmea0183"}


@pytest.fixture(scope="module")
def shared_files() -> dict[str, Path]:
    if not SHARED.is_dir():
        pytest.skip(f"../shared data not here: {SHARED} not found")
    return {f"{p.parent.name}/{p.name}": p for p in sorted(SHARED.glob("*/*")) if p.is_file()}


def test_the_installed_readers_and_their_order():
    readers = dict(log_readers(Registry()))
    order = [n for n in readers if n in ("mcap", "candump", "actisense_plain", "ydwg_raw", "ikonvert", "nmea0183")]
    assert order == ["mcap", "candump", "actisense_plain", "ydwg_raw", "ikonvert", "nmea0183"]
    assert list(readers)[0] == "mcap" and list(readers)[-1] == "nmea0183"  # a magic first, NMEA 0183 last
    for name, reader in readers.items():
        assert reader.name == name
    assert (readers["mcap"].protocol, readers["mcap"].input) == ("", None)
    assert {(readers[n].protocol, readers[n].input) for n in HEALTH_TYPE if n != "nmea0183"} == {("can", "can")}
    assert (readers["nmea0183"].protocol, readers["nmea0183"].input) == ("nmea0183", "nmea0183")


def test_every_shared_file_is_detected_as_before(shared_files):
    """Every file there is listed (a new file must be added here with its reader)."""
    reg = Registry()
    assert sorted(shared_files) == sorted(DETECTED)
    got = {key: detect(path, reg)[0] for key, path in shared_files.items()}
    assert got == DETECTED


def test_the_mcap_magic_is_the_recordings(tmp_path):
    from edged_mcap import logs, reading

    assert logs.MAGIC == reading.MAGIC
    p = tmp_path / "r.mcap"
    p.write_bytes(reading.MAGIC + b"\x00" * 64)
    assert detect(p, Registry())[0] == "mcap"


def test_replay_of_a_shared_log_keeps_the_file_health_type(shared_files, tmp_path):
    """The health records a replay publishes name each file's input type, as before."""
    import asyncio

    from edged.clock import ReplayClock
    from edged.config import parse_config
    from edged.replay import Replayer
    from edged.runtime import Runtime

    reg = Registry()
    for key in ("n2k/canboat__samples__ikonvert.log", "nmea0183/gpsd__test__daemon__saab-r4.log"):
        path = shared_files[key]
        rt = Runtime(parse_config({}, reg), reg, ReplayClock(), replay=True)

        async def go() -> None:
            await rt.start()
            try:
                await Replayer(rt, [path]).run()
            finally:
                await rt.stop()

        asyncio.run(go())
        h = rt.health.components[f"input:{path.stem}"]
        assert h.type == HEALTH_TYPE[DETECTED[key]], key


_PROBE = """
import sys
from pathlib import Path
from edged.registry import Registry
from edged.logformats import detect
print(detect(Path(sys.argv[1]), Registry())[0])
print(" ".join(sorted(m for m in sys.modules if m.split(".")[0] in {MODULES})))
"""


def _imports_of_detect(path: Path, modules: set[str]) -> tuple[str, set[str]]:
    out = subprocess.run(
        [sys.executable, "-c", _PROBE.replace("{MODULES}", repr(modules)), str(path)],
        capture_output=True, text=True, check=True, timeout=60,
    ).stdout.splitlines()
    return out[0], set(out[1].split()) if len(out) > 1 else set()


@pytest.mark.parametrize("key", ["n2k/canboat__samples__candumpSample1.txt", "n2k/canboat__samples__ikonvert.log",
                                 "nmea0183/gpsd__test__daemon__saab-r4.log"])
def test_detect_imports_no_decoding_stack(shared_files, key):
    """Sniffing loads every reader: none may import cantools, nmea2000, python-can or
    the mcap library (the CAN decoder's and the recorder's stacks)."""
    name, heavy = _imports_of_detect(shared_files[key], {"cantools", "nmea2000", "can", "mcap"})
    assert name == DETECTED[key] and heavy == set()


def test_detect_of_a_can_log_does_not_import_the_nmea0183_decoder(shared_files):
    name, heavy = _imports_of_detect(
        shared_files["n2k/canboat__samples__candumpSample1.txt"], {"numpy", "edged_nmea0183"}
    )
    assert name == "candump"
    assert "edged_nmea0183.decoder" not in heavy and "numpy" not in heavy
