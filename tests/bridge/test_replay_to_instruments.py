"""A replay sends the bridge's instruments what it records (issue 35): a simulated
voyage replayed with the STW and manoeuvre estimators, `--record`, the NMEA 0183
output on UDP and the NMEA 2000 output on a python-can `virtual` bus. What a socket
and another node on the bus receive, decoded by pynmea2 and by the `nmea2000`
package (fast-packet included), equals the recorded estimates within each format's
resolution; what was stale or converging went out as "not available"."""

from __future__ import annotations

import json
import math
import socket
import threading
import uuid
from pathlib import Path
from typing import Any

import can
import pynmea2
import pytest
from nmea2000 import NMEA2000Decoder

from edged.cli import main
from edged.units import KNOT
from edged_mcap.reading import ReadReport, iter_messages

pytestmark = pytest.mark.timeout(240)
SPEED, ANGLE = 0.01 / 2, 1e-4 / 2  # N2K resolutions (m/s, rad), half a step
DEG = 180.0 / math.pi


def _valid(e: dict[str, Any], field: str) -> float | None:
    v = e.get(field)
    ok = not e.get("stale") and not e.get("converging") and isinstance(v, (int, float)) and math.isfinite(v)
    return float(v) if ok else None


def _estimates(record: Path) -> dict[str, list[dict[str, Any]]]:
    out: dict[str, list[dict[str, Any]]] = {}
    for p in sorted(record.parent.glob(record.stem + "*.mcap")):
        with p.open("rb") as f:
            for ch, _, msg in iter_messages(f, ReadReport()):
                if ch.topic.startswith("/est/"):
                    out.setdefault(ch.topic[5:], []).append(json.loads(msg.data))
    return out


class UdpCollector:
    """Datagrams to a local port, read by a thread while the replay runs."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.port = self.sock.getsockname()[1]
        self.data: list[bytes] = []
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.stop.is_set():
            try:
                self.data.append(self.sock.recv(65536))
            except TimeoutError:
                continue

    def finish(self) -> list[pynmea2.NMEASentence]:
        self.stop.set()
        self.thread.join()
        self.sock.close()
        return [pynmea2.parse(line, check=True) for d in self.data for line in d.decode("ascii").splitlines()]


def _replay(work: Path, sim: Path, workers: str) -> dict[str, Any]:
    """Replay the simulated voyage with both estimators in `workers` ("process", their
    default, or "loop"): what the UDP socket and the bus got, and the recording."""
    udp = UdpCollector()
    channel = f"bridge-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    cfg = work / f"edged-{workers}.toml"
    cfg.write_text(f"""
[estimators.stw]
type = "stw"
worker = "{workers}"
[estimators.manoeuvre]
type = "manoeuvre"
worker = "{workers}"
[outputs.nmea]
type = "nmea0183"
transport = "udp"
port = {udp.port}
rates = {{ HDT = 100, ROT = 100, VHW = 100, VDR = 100 }}  # every estimate (rates: tests/nmea0183)
[outputs.n2k]
type = "nmea2000"
interface = "virtual"
channel = "{channel}"
rates = {{ 127250 = 100, 127251 = 100, 128259 = 100, 130577 = 100 }}
""")
    record = work / f"run-{workers}.mcap"
    try:
        rc = main(["replay", "-c", str(cfg), "--no-zenoh", "--no-progress", "--record", str(record),
                   str(sim / "nmea.log"), str(sim / "can.log")])
        frames = []
        while (m := bus.recv(timeout=0)) is not None:
            frames.append(m)
    finally:
        bus.shutdown()
    assert rc == 0
    decoder = NMEA2000Decoder(units="si")
    n2k: dict[int, list[dict[str, Any]]] = {}
    for f in frames:
        d = decoder.decode(f)
        if d is not None and d.source != 254:
            n2k.setdefault(d.PGN, []).append({x.id: x.value for x in d.fields})
    raw = list(udp.data)
    return {"est": _estimates(record), "nmea": udp.finish(), "nmea_bytes": raw, "n2k": n2k}


@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    work = tmp_path_factory.mktemp("bridge")
    assert main(["sim", "demo", "--out", str(work / "sim"), "--duration", "120", "--seed", "3"]) == 0
    return work, work / "sim"


@pytest.fixture(scope="module")
def voyage(simulated: tuple[Path, Path]) -> dict[str, Any]:
    return _replay(*simulated, "process")


def _same(sent: list[float | None], want: list[float | None], tol: float) -> None:
    assert len(sent) == len(want)
    for i, (s, w) in enumerate(zip(sent, want)):
        assert (s is None) == (w is None), (i, s, w)
        if w is not None:
            assert abs(s - w) <= tol, (i, s, w)


def _field(x: Any) -> float | None:
    """A field pynmea2 read: None when empty (it gives "" or None; 0.0 is a value)."""
    return None if x is None or x == "" else float(x)


def _bearing(rad: float | None) -> float | None:
    return None if rad is None else math.degrees(rad) % 360.0


def test_nmea0183_sentences_are_the_recorded_estimates(voyage: dict[str, Any]) -> None:
    man, stw = voyage["est"]["manoeuvre"], voyage["est"]["stw"]
    by: dict[str, list[Any]] = {}
    for s in voyage["nmea"]:
        by.setdefault(s.sentence_type, []).append(s)
    hdt = [_field(s.heading) for s in by["HDT"]]
    want = [_bearing(_valid(e, "heading")) for e in man]
    assert sum(w is not None for w in want) > len(want) // 2  # the test has numbers to compare
    _same([h if h is None or h < 359.95 else h - 360.0 for h in hdt],
          [w if w is None or w < 359.95 else w - 360.0 for w in want], 0.05 + 1e-9)
    rot = [_field(s.rate_of_turn) for s in by["ROT"]]
    _same(rot, [None if (r := _valid(e, "r")) is None else r * DEG * 60.0 for e in man], 0.05 + 1e-9)
    assert all((s.status == "A") == (_field(s.rate_of_turn) is not None) for s in by["ROT"])
    vhw = [None if (k := _field(s.water_speed_knots)) is None else k * KNOT for s in by["VHW"]]
    _same(vhw, [_valid(e, "stw") for e in stw], 0.005 * KNOT + 1e-9)
    vdr = [None if (k := _field(s.current)) is None else k * KNOT for s in by["VDR"]]
    _same(vdr, [_valid(e, "current") for e in stw], 0.005 * KNOT + 1e-9)


def test_nmea2000_pgns_are_the_recorded_estimates(voyage: dict[str, Any]) -> None:
    man, stw, n2k = voyage["est"]["manoeuvre"], voyage["est"]["stw"], voyage["n2k"]
    # Nothing goes before the address is claimed (the first data second of a replay):
    # the messages sent are the last ones, in order.
    heading = [m["heading"] for m in n2k[127250]]
    assert len(man) - 15 <= len(heading) <= len(man)
    _same(heading, [_valid(e, "heading") for e in man[len(man) - len(heading):]], ANGLE)
    rate = [m["rate"] for m in n2k[127251]]
    _same(rate, [_valid(e, "r") for e in man[len(man) - len(rate):]], 3.125e-8 / 2 + 1e-12)
    water = [m["speedWaterReferenced"] for m in n2k[128259]]
    assert len(stw) - 3 <= len(water) <= len(stw)
    _same(water, [_valid(e, "stw") for e in stw[len(stw) - len(water):]], SPEED)
    direction = n2k[130577]  # a fast-packet of several frames
    assert len(direction) == len(water)
    _same([m["drift"] for m in direction], [_valid(e, "current") for e in stw[len(stw) - len(direction):]], SPEED)
    _same([m["set"] for m in direction], [_valid(e, "current_set") for e in stw[len(stw) - len(direction):]], ANGLE)


def test_what_combines_two_estimators_is_the_same_whatever_their_pace(
        voyage: dict[str, Any], simulated: tuple[Path, Path]) -> None:
    """VHW goes with each STW estimate, the manoeuvring state's latest heading beside
    it. In processes of their own the two estimators run seconds of data apart in a
    replay; in the loop they do not. The output takes their estimates in the order of
    the records they were made from, so it sends the same sentences either way."""
    again = _replay(*simulated, "loop")
    assert again["est"] == voyage["est"]
    sent = [s for s in voyage["nmea"] if s.sentence_type == "VHW"]
    assert sum(1 for s in sent if _field(s.heading_true) is not None) > len(sent) // 2
    assert b"".join(again["nmea_bytes"]) == b"".join(voyage["nmea_bytes"])
