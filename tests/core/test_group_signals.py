"""Hardening, second round (issue 32): a stop signal to the daemon's whole process
group, as Ctrl-C in a terminal and `systemctl stop` (KillMode=control-group) send it,
while it records with the recorder in a process of its own.

Before, the group's SIGTERM killed the recorder's process before the daemon could
finish the file: the MCAP needed `edged recover`, and the daemon still exited 0. Now the
children ignore the stop signals (`edged.signals.ignore_stop_signals`, and from their
first import, `edged/__init__.py`), the parent drains them and finishes the file."""

from __future__ import annotations

import os
import queue
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from nmea_text import sentence


def _cs(body: str) -> str:
    return sentence(body) + "\r\n"


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGQUIT, signal.SIGUSR1])
def test_a_stop_signal_to_the_whole_group_leaves_a_finished_recording_and_exit_0(tmp_path: Path, sig):
    """SIGUSR1, which means nothing to edged, is logged and ignored by every process
    of the group (its default ended them: the file unfinished); SIGTERM then stops."""
    from mcap.reader import make_reader

    port = _free_udp_port()
    rec = tmp_path / "rec"
    cfg = tmp_path / "edged.toml"
    cfg.write_text(
        f'[edged]\nvessel_id = "t1"\n\n[inputs.gps]\ntype = "nmea0183"\ntransport = "udp"\nport = {port}\n\n'
        f'[outputs.recorder]\ntype = "mcap"\ndirectory = "{rec}"\nmin_free_gib = 0.0\n'
    )
    proc = subprocess.Popen(
        [sys.executable, "-m", "edged.cli", "--log-level", "info", "run", "-c", str(cfg)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"}, start_new_session=True,
    )
    lines: queue.Queue[str | None] = queue.Queue()

    def read() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()
    seen: list[str] = []

    def wait_for(*texts: str) -> None:
        """Until each of `texts` was in some line of the daemon's log (any order)."""
        left = set(texts)
        while left:
            try:
                line = lines.get(timeout=60)
            except queue.Empty:
                raise AssertionError(f"nothing for 60 s while waiting for {left}: " + "".join(seen)) from None
            if line is None:
                raise AssertionError(f"the daemon ended before {left}: " + "".join(seen))
            seen.append(line)
            left = {t for t in left if t not in line}

    sent = 20
    try:
        # the recorder's process is up and recording, the UDP input listens
        wait_for("event=recording", "component=gps role=input state=connected")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for k in range(sent):
                s.sendto(_cs(f"GPRMC,0820{k:02d}.00,A,5400.000,N,01000.000,E,0.0,0.0,041226,,,A").encode(),
                         ("127.0.0.1", port))
            bad = _cs("GPRMC,082059.00,A,5400.000,N,01000.000,E,0.0,0.0,041226,,,A")
            s.sendto((bad[:-4] + ("00" if bad[-4:-2] != "00" else "01") + "\r\n").encode(), ("127.0.0.1", port))
        # the last datagram's rejection is logged: the ones before it were read (no
        # sleep: we wait for what the daemon says)
        wait_for("rejected NMEA 0183 line: checksum")
        os.killpg(proc.pid, sig)
        if sig == signal.SIGUSR1:
            wait_for("event=signal-ignored signal=SIGUSR1")
            assert proc.poll() is None
            os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    while True:
        line = lines.get(timeout=30)
        if line is None:
            break
        seen.append(line)
    log = "".join(seen)
    assert proc.returncode == 0, log
    assert "Traceback" not in log and "KeyboardInterrupt" not in log
    files = sorted(rec.glob("edged-*.mcap"))
    assert files, log
    for f in files:
        with open(f, "rb") as fh:
            summary = make_reader(fh).get_summary()  # a finished file has its summary
        assert summary is not None and summary.statistics is not None, f
    raw = 0
    for f in files:
        with open(f, "rb") as fh:
            raw += sum(1 for _, ch, _ in make_reader(fh).iter_messages(topics=["/raw/nmea0183/gps"]))
    assert raw == sent, (raw, log)  # every good datagram (the bad one was rejected, counted)
