"""deploy/zenoh/make-test-certs.sh (issue 16): a CA, the router's and the clients'
certificates; run again on the same folder it adds certificates signed by the CA
already there, so that adding a vessel never invalidates the fleet's others."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "deploy" / "zenoh" / "make-test-certs.sh"
pytestmark = pytest.mark.skipif(shutil.which("openssl") is None, reason="openssl is not installed")


def _verify(folder: Path, name: str) -> bool:
    r = subprocess.run(["openssl", "verify", "-CAfile", str(folder / "ca.pem"), str(folder / f"{name}.pem")],
                       capture_output=True, text=True, timeout=60)
    return r.returncode == 0


def _subject(folder: Path, name: str) -> str:
    return subprocess.run(["openssl", "x509", "-in", str(folder / f"{name}.pem"), "-noout", "-subject"],
                          capture_output=True, text=True, timeout=60, check=True).stdout


def test_a_second_run_adds_a_vessel_under_the_same_ca(tmp_path):
    d = tmp_path / "pki"
    subprocess.run(["sh", str(SCRIPT), str(d), "vessel-1", "fleet-dashboard"], check=True, capture_output=True,
                   timeout=120)
    ca, router = (d / "ca.pem").read_bytes(), (d / "router.pem").read_bytes()
    assert all(_verify(d, n) for n in ("router", "vessel-1", "fleet-dashboard"))
    assert "CN = vessel-1" in _subject(d, "vessel-1")
    r = subprocess.run(["sh", str(SCRIPT), str(d), "vessel-3"], check=True, capture_output=True, text=True,
                       timeout=120)
    assert "the CA already there" in r.stdout
    assert (d / "ca.pem").read_bytes() == ca and (d / "router.pem").read_bytes() == router
    assert _verify(d, "vessel-1") and _verify(d, "vessel-3")  # the old one still trusted
    assert not list(d.glob("*.cnf")) and not list(d.glob("*.csr"))
    assert (d / "vessel-3.key").stat().st_mode & 0o077 == 0  # keys readable by their owner only


@pytest.mark.parametrize("name", ["../x", ".hidden", ""])
def test_a_name_that_is_no_certificate_name_is_refused(tmp_path, name):
    r = subprocess.run(["sh", str(SCRIPT), str(tmp_path / "pki"), name], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "not a certificate name" in r.stderr
