"""A zenoh peer in its own process, driven by tests through stdin/stdout lines.

Prints (one line each, flushed):
  `alive put|delete <key>`     liveliness of `<prefix>/alive`
  `ready`                      subscribed, and the publisher side has seen our declarations
  `sample <key> <encoding> <payload>`
  `reply <key> <payload>` ... `end`   answer to a `get <selector>` line on stdin
Stdin `quit` (or end of input) closes the session and exits.

Readiness proof: once the publisher's liveliness token is seen, a `get` is sent on the
same link after our subscriber declaration; its completion means the other side has
processed the declaration, so nothing published afterwards can be missed.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading

import zenoh


def say(*parts: str) -> None:
    sys.stdout.write(" ".join(parts) + "\n")
    sys.stdout.flush()


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--prefix", required=True)
    ap.add_argument("--connect", action="append", default=[])
    ap.add_argument("--listen", action="append", default=[])
    ap.add_argument("--mode", default="peer")
    ap.add_argument("--no-wait-alive", action="store_true", help="say ready without waiting for liveliness")
    a = ap.parse_args()

    cfg = zenoh.Config()
    cfg.insert_json5("mode", json.dumps(a.mode))
    cfg.insert_json5("listen/endpoints", json.dumps(a.listen))
    cfg.insert_json5("connect/endpoints", json.dumps(a.connect))
    cfg.insert_json5("scouting/multicast/enabled", "false")
    cfg.insert_json5("scouting/gossip/enabled", "false")
    session = zenoh.open(cfg)
    lock = threading.Lock()
    alive_seen = threading.Event()

    def on_sample(s: zenoh.Sample) -> None:
        with lock:
            say("sample", str(s.key_expr), str(s.encoding), s.payload.to_bytes().decode())

    def on_alive(s: zenoh.Sample) -> None:
        with lock:
            say("alive", "put" if s.kind == zenoh.SampleKind.PUT else "delete", str(s.key_expr))
        if s.kind == zenoh.SampleKind.PUT:
            alive_seen.set()

    sub = session.declare_subscriber(f"{a.prefix}/**", on_sample)
    live = session.liveliness().declare_subscriber(f"{a.prefix}/alive", on_alive, history=True)
    if not a.no_wait_alive:
        if not alive_seen.wait(30):
            say("error", "no-liveliness")
            return 1
        for _ in session.get(f"{a.prefix}/**", timeout=10):
            pass
    say("ready")
    for line in sys.stdin:
        cmd, _, arg = line.strip().partition(" ")
        if cmd == "get":
            replies = [r.ok for r in session.get(arg, timeout=10) if r.ok is not None]
            with lock:
                for r in replies:
                    say("reply", str(r.key_expr), r.payload.to_bytes().decode())
                say("end")
        elif cmd == "quit":
            break
    live.undeclare()
    sub.undeclare()
    session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
