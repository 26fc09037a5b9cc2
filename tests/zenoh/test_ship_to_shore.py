"""Ship to shore through two routers (issue 16): the daemon's tools publish to the ship's
router (deploy/zenoh/router.json5, its shore link uncommented as the file says, with the
vessel's certificate), which links to the shore router (router-tls.json5) over mutual
TLS; the shore's dashboard sees the vessel's data, and the vessel's data only under its
own prefix (the shore's access control judges the ship router by its certificate)."""

from __future__ import annotations

import json
from pathlib import Path

import json5
import zenoh

from zenoh_tls import pki  # noqa: F401 (the fixture)
from zenoh_tls import DASHBOARD, REPO, Pki, Seen, free_port, router_config, start_router, tls_session, wait_matching

SHIP = REPO / "deploy" / "zenoh" / "router.json5"


def ship_router_config(pki: Pki, shore: str, listen: str, path: Path) -> Path:
    """router.json5 with its listen endpoint on a free port and the shore link of its
    comments switched on: `connect` to the shore, the `transport.link.tls` block with
    the vessel's certificate."""
    cfg = json5.loads(SHIP.read_text())
    text = SHIP.read_text()
    for key in ("root_ca_certificate", "connect_certificate", "connect_private_key", "enable_mtls"):
        assert f"//       {key}" in text, f"router.json5's shore link no longer names {key}"
    cfg["listen"]["endpoints"] = [listen]
    cfg["connect"]["endpoints"] = [shore]
    cfg["transport"] = {"link": {"tls": {
        "root_ca_certificate": pki.ca, "connect_certificate": pki.cert("vessel-1"),
        "connect_private_key": pki.key("vessel-1"), "verify_name_on_connect": True, "enable_mtls": True,
    }}}
    path.write_text(json.dumps(cfg, indent=2))
    return path


def local_session(endpoint: str) -> zenoh.Session:
    cfg = zenoh.Config()
    for key, value in {"mode": "client", "connect/endpoints": [endpoint], "listen/endpoints": [],
                       "scouting/multicast/enabled": False, "scouting/gossip/enabled": False}.items():
        cfg.insert_json5(key, json.dumps(value))
    return zenoh.open(cfg)


def test_a_vessels_data_reaches_the_shore_through_the_ships_router_and_only_its_own(pki: Pki, tmp_path: Path):
    shore_ep = f"tls/127.0.0.1:{free_port()}"
    ship_ep = f"tcp/127.0.0.1:{free_port()}"
    shore = start_router(router_config(pki, shore_ep, tmp_path / "shore.json5", acl=True))
    ship = None
    sessions: list[zenoh.Session] = []
    try:
        watch = tls_session(pki, shore_ep, DASHBOARD)
        sessions.append(watch)
        seen = Seen()
        sub = watch.declare_subscriber("vessel/**", seen)
        ship = start_router(ship_router_config(pki, shore_ep, ship_ep, tmp_path / "ship.json5"))
        local = local_session(ship_ep)  # the daemon or a tool on board: plain TCP on loopback
        sessions.append(local)
        own = "vessel/vessel-1/est/stw"
        pub = local.declare_publisher(own)
        wait_matching(pub)  # the ship router linked to the shore and knows its subscriber
        pub.put("first")
        seen.wait(own, "first")
        pub.undeclare()
        local.put("vessel/vessel-2/est/stw", "forged-after-link")
        marker = "after-the-forgery"
        local.put(own, marker)
        seen.wait(own, marker)
        assert not [item for item in seen.snapshot() if item[0].startswith("vessel/vessel-2/")]
        sub.undeclare()
    finally:
        for s in sessions:
            s.close()
        if ship is not None:
            ship.stop()
        shore.stop()
