"""Bench: the manoeuvring-state estimator on the real logs of ../shared/data (issue 13,
"Real data"), the figures behind tests/manoeuvre/test_real_logs.py.

Run: .venv/bin/python tests/bench/manoeuvre_real.py [log ...] [--defaults] [--set k=v ...]

Each log is fed as tests/support/manoeuvre_real.py says (one source per kind, the first
seen; a fix counted once; NMEA 0183 sentences that share one time stamp spread over
the second; tick on a 0.1 s grid of data time, restarted after a gap), with the
default core plus the log's `config` (init_window for 1 Hz GNSS) unless `--defaults`.
Printed per log: duration, measurements per kind and source (the one fed marked *),
fixes dropped as repeats and records spread, per kind the updates, gated, NIS mean,
median and share in the two-sided 95 % band and above it, divergences, the sensor σ
learned (health's `sensor_sigma`), the process-noise scale, and the yaw rate: raw
noise against filtered (std of first differences on one grid, RMS of raw - filtered),
the manoeuvre content (max |r| raw and filtered, heading range), sog against the
log's own, and the CPU time.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))

import manoeuvre_real as mr  # noqa: E402

DEG = 180.0 / math.pi


def _value(s: str):
    try:
        return json.loads(s)
    except json.JSONDecodeError:
        return s


def report(name: str, defaults: bool, overrides: dict) -> dict:
    r = mr.run(name, log_config=not defaults, **overrides)
    h = r.core.health()
    fed = r.fed_sources()
    print(f"== {name}: {r.log.path}")
    print(f"   {r.log.vessel}")
    cfg = {} if defaults else dict(r.log.config)
    cfg.update(overrides)
    print(f"   config {cfg or 'defaults'}; duration {r.duration():.1f} s (gaps > {mr.GAP:.0f} s: {r.gaps()}); estimates {len(r.out)}; "
          f"cpu {r.cpu:.2f} s; error {r.error}")
    counts = r.counts()
    by_kind: dict[str, list[str]] = {}
    for (k, src), n in sorted(counts.items()):
        by_kind.setdefault(k, []).append(f"{src}{'*' if fed.get(k) == src else ''}:{n}")
    print("   measurements " + "; ".join(f"{k} {' '.join(v)}" for k, v in by_kind.items()))
    print(f"   fixes dropped as repeats {r.dropped_fixes}; records spread over their second {r.spread}")
    row = {"log": name, "duration": round(r.duration(), 1), "estimates": len(r.out),
           "divergences": h["divergences"]}
    for kind in ("position", "heading", "yaw_rate", "accel_body"):
        s = r.nis(kind)
        if not s["updates"] and not s["gated"]:
            continue
        if s["updates"]:
            print(f"   {kind:9s} updates {s['updates']:5d} gated {s['gated']:4d}  NIS mean {s['mean']:.3f} "
                  f"median {s['median']:.3f} (dof {s['dof']})  in 95% band {100 * s['band']:.1f} %  "
                  f"above {100 * s['above']:.1f} %")
        else:
            print(f"   {kind:9s} updates 0 gated {s['gated']}")
        row[kind] = s
    print(f"   divergences {h['divergences']}  rejected {h['rejected']}  events {h['events']}  "
          f"q_scale {h['q_scale']}")
    sig = {}
    for key, vals in h["sensor_sigma"].items():
        kind = key.split("/")[0]
        if kind in ("heading", "yaw_rate"):
            sig[kind] = f"{vals[0] * DEG:.4f} deg{'/s' if kind == 'yaw_rate' else ''}"
        else:
            sig[kind] = " ".join(f"{v:.3f}" for v in vals) + " m" + ("/s2" if kind == "accel" else "")
    print(f"   sensor sigma learned {sig}")
    y = r.yaw_noise()
    if y:
        print(f"   yaw rate ({int(y['samples'])} samples): first-difference std raw {y['raw_diff_std'] * DEG:.4f} "
              f"filtered {y['filtered_diff_std'] * DEG:.4f} deg/s (ratio {y['filtered_diff_std'] / y['raw_diff_std']:.3f}); "
              f"RMS raw - filtered {y['rms_raw_minus_filtered'] * DEG:.4f} deg/s; raw std {y['raw_std'] * DEG:.4f} deg/s")
        row["yaw"] = y
    if r.out:
        _, rr = r.series("r")
        print(f"   manoeuvre: max |r| filtered {max(abs(rr)) * DEG:.3f} deg/s"
              + (f", raw {y['max_abs_raw'] * DEG:.3f} deg/s" if y else "")
              + f"; heading range {r.heading_range() * DEG:.2f} deg")
        _, u = r.series("u")
        _, v = r.series("v")
        print(f"   u {u.min():.2f}..{u.max():.2f} m/s, v {v.min():.2f}..{v.max():.2f} m/s")
        s = r.sog_check()
        if s:
            print(f"   sog vs {s['what']}: {s['n']} pairs, median |diff| {s['median_abs']:.3f} m/s, "
                  f"max {s['max_abs']:.3f} m/s")
        row["heading_range_deg"] = r.heading_range() * DEG
    print()
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("logs", nargs="*", help=f"some of {', '.join(mr.LOGS)} (default: all there)")
    ap.add_argument("--defaults", action="store_true", help="every config default (no init_window per log)")
    ap.add_argument("--set", action="append", default=[], metavar="K=V", help="a ManoeuvreConfig field")
    a = ap.parse_args()
    overrides = {k: _value(v) for k, v in (s.split("=", 1) for s in a.set)}
    names = a.logs or [n for n in mr.LOGS if mr.available(n)]
    if not names:
        sys.exit(f"no log found under {mr.DATA}")
    rows = [report(n, a.defaults, overrides) for n in names]
    print("summary: log | s | est | div | NIS mean (gated %) position, heading, yaw_rate | "
          "yaw diff-std raw/filtered deg/s | heading range deg")
    for row in rows:
        cells = []
        for kind in ("position", "heading", "yaw_rate"):
            s = row.get(kind)
            if not s:
                cells.append("-")
            elif not s["updates"]:
                cells.append(f"- ({s['gated']} gated)")
            else:
                cells.append(f"{s['mean']:.2f} ({100 * s['gated'] / (s['updates'] + s['gated']):.0f}%)")
        y = row.get("yaw")
        yc = f"{y['raw_diff_std'] * DEG:.4f}/{y['filtered_diff_std'] * DEG:.4f}" if y else "-"
        print(f"  {row['log']:15s} | {row['duration']:6.1f} | {row['estimates']:5d} | {row['divergences']} | "
              f"{' | '.join(cells)} | {yc} | {row.get('heading_range_deg', 0.0):.1f}")


if __name__ == "__main__":
    main()
