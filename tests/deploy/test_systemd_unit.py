"""The systemd unit and its installer (issue 16): `systemd-analyze verify` passes, the
exposure score of `systemd-analyze security` is 2.0 or lower, and `install.sh` is
idempotent (a second run changes nothing, the operator's configuration is kept).
Skipped where systemd-analyze is absent; systemd need not run (the unit is analysed
offline; the notify protocol is tested in tests/core/test_sdnotify.py)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
UNIT = ROOT / "deploy" / "edged.service"
INSTALL = ROOT / "deploy" / "install.sh"
ANALYZE = shutil.which("systemd-analyze")
needs_analyze = pytest.mark.skipif(ANALYZE is None, reason="systemd-analyze is not installed")


def _settings(text: str) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith(("#", "[")) and "=" in line:
            k, v = line.split("=", 1)
            out.setdefault(k, []).append(v)
    return out


def _unit_here(tmp_path: Path) -> Path:
    """The unit with ExecStart pointing at this checkout's `edged` (verify checks that
    the program exists)."""
    edged = Path(sys.executable).with_name("edged")
    assert edged.exists(), edged
    text = UNIT.read_text().replace("/opt/edged/venv/bin/edged", str(edged))
    out = tmp_path / "edged.service"
    out.write_text(text)
    return out


def test_the_unit_is_a_notify_service_with_a_watchdog_restarted_on_failure():
    s = _settings(UNIT.read_text())
    assert s["Type"] == ["notify"] and s["NotifyAccess"] == ["main"]
    assert s["Restart"] == ["on-failure"] and float(s["WatchdogSec"][0]) > 0
    assert s["User"] == ["edged"] and s["Group"] == ["edged"]
    assert s["CapabilityBoundingSet"] == [""] and s["NoNewPrivileges"] == ["yes"]
    assert s["ProtectSystem"] == ["strict"] and s["ReadWritePaths"] == ["/var/lib/edged"]
    assert set(s["RestrictAddressFamilies"][0].split()) == {"AF_UNIX", "AF_INET", "AF_INET6", "AF_CAN", "AF_NETLINK"}
    assert s["ExecStart"][0].endswith("edged run -c /etc/edged/edged.toml")
    assert s["ExecReload"] == ["/bin/kill -HUP $MAINPID"]  # rotates the recording


@needs_analyze
def test_systemd_analyze_verify_passes(tmp_path):
    unit = _unit_here(tmp_path)
    r = subprocess.run([ANALYZE, "verify", str(unit)], capture_output=True, text=True, timeout=120)
    complaints = [ln for ln in (r.stdout + r.stderr).splitlines() if "edged.service" in ln]
    assert r.returncode == 0 and not complaints, r.stdout + r.stderr


@needs_analyze
def test_the_exposure_score_is_at_most_2(tmp_path):
    unit = _unit_here(tmp_path)
    r = subprocess.run([ANALYZE, "security", "--offline=yes", str(unit)], capture_output=True, text=True,
                       timeout=120)
    m = re.search(r"Overall exposure level for edged\.service: ([0-9.]+)", r.stdout + r.stderr)
    assert m, r.stdout + r.stderr
    assert float(m.group(1)) <= 2.0, r.stdout


def test_install_into_a_staging_root_is_idempotent_and_keeps_the_configuration(tmp_path):
    root = tmp_path / "root"
    env = {**os.environ, "DESTDIR": str(root), "EDGED_PIP": "0", "PYTHON": sys.executable}
    first = subprocess.run(["sh", str(INSTALL)], capture_output=True, text=True, env=env, timeout=300)
    assert first.returncode == 0, first.stdout + first.stderr
    conf = root / "etc/edged/edged.toml"
    unit = root / "etc/systemd/system/edged.service"
    assert conf.read_text() == (ROOT / "deploy/edged.toml").read_text()
    assert unit.read_text() == UNIT.read_text()
    assert (root / "opt/edged/venv/bin/python").exists()
    assert (root / "var/lib/edged").is_dir() and (root / "var/lib/edged").stat().st_mode & 0o777 == 0o750
    conf.write_text(conf.read_text().replace('vessel_id = "mv-example"', 'vessel_id = "mv-ours"'))
    second = subprocess.run(["sh", str(INSTALL)], capture_output=True, text=True, env=env, timeout=300)
    assert second.returncode == 0, second.stdout + second.stderr
    assert 'vessel_id = "mv-ours"' in conf.read_text()  # the operator's file is kept
    assert "kept as it is" in second.stdout
    assert "installed" not in second.stdout and "created" not in second.stdout  # nothing else changed


def test_install_refuses_to_run_as_a_user_without_a_staging_root(tmp_path):
    if os.geteuid() == 0:
        pytest.skip("running as root: the installer would install")
    env = {k: v for k, v in os.environ.items() if k != "DESTDIR"}
    r = subprocess.run(["sh", str(INSTALL)], capture_output=True, text=True, env=env, timeout=60)
    assert r.returncode == 2 and "run as root" in r.stderr
