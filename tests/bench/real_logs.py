"""Real-log harness (issue 30): the default configuration on the real logs of
../shared/data, scored against what the logs themselves contain. Run on demand.

    .venv/bin/python tests/bench/real_logs.py [log ...] [--jobs 2] [--out DIR] [--reuse]

The logs are tests/support/manoeuvre_real.py's `LOGS` (those present) and every other
file of the data folder (`--listed`: only the former), each replayed as a user would: `edged replay LOG --no-zenoh --record` with the built-in default
configuration (`--date` where the log needs one). From the recording:
- state: underway when the median GNSS SOG is above 0.5 m/s (or the fixes' speed over
  10 s when the log has no SOG), else still; the berth logs are dirona, susteranna,
  susteranna2020 and can0-1; every log with GNSS fixes is tabled;
- prediction (est/manoeuvre `predicted`, the rows made at an estimate's own instant,
  dt within 0.05 s of 10, 30 and 60 s): the error at the due time against the GNSS fixes
  of the most frequent position source interpolated to it (only where fixes lie within
  5 s either side), beside dead reckoning from the last fix at or before the prediction
  carried forward at the last SOG/COG (or, without any, the velocity of the fixes over
  the last 5 s), the honest baseline (ESTIMATORS.md); their RMS and ratio, and the share
  of fixes inside the 2σ ellipse (std_major, std_minor, std_angle: the major axis from
  north clockwise; 86.5 % for a Gaussian);
- SOG: the largest estimated SOG (manoeuvre and stw) and the largest GNSS SOG, in kn;
- heading: the estimate minus each heading source (the estimate published last before
  each reading), median and RMS in degrees;
- stw: the estimate minus the log it reads (`dvl_stw`) and minus its own `sog`, its
  `stw_std` (median, largest, the first estimate's) and the log offset it found;
- health: the share of snapshots with the estimator `ok: false`, and the problems named.
Stale estimates are left out; `converging` ones are counted.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "support"))

from harness import DEG, health_of, num, problems_seen, read, replay, table  # noqa: E402
from manoeuvre_real import DATA, LOGS, Log  # noqa: E402

from edged.geo import LocalPlane  # noqa: E402

BERTH = ("dirona", "susteranna", "susteranna2020", "can0-1")
HORIZONS = (10.0, 30.0, 60.0)
KN = 3600.0 / 1852.0
FIX_GAP = 5.0  #: s: a due time is judged only with fixes this close on both sides


def _wrap_deg(x: np.ndarray) -> np.ndarray:
    return (x + 180.0) % 360.0 - 180.0


def _series(payloads: list[dict[str, Any]], *keys: str) -> tuple[np.ndarray, ...]:
    """t and the named values (NaN where null) of measurements, sorted by t."""
    rows = [(p["t"], *[p.get(k) if isinstance(p.get(k), (int, float)) else math.nan for k in keys]) for p in payloads]
    rows.sort(key=lambda r: r[0])
    a = np.array(rows, dtype=float).reshape(-1, 1 + len(keys))
    return tuple(a[:, i] for i in range(a.shape[1]))


def _by_source(rec, kind: str) -> dict[str, list[dict[str, Any]]]:
    pre = f"/meas/{kind}/"
    return {t[len(pre):]: p for t, p in rec.topics.items() if t.startswith(pre)}


def predictions(est: list[dict[str, Any]], fixes: tuple[np.ndarray, ...], vel: tuple[np.ndarray, ...] | None,
                plane: LocalPlane) -> dict[float, dict[str, Any]]:
    """Per horizon: RMS error of the predictions and of dead reckoning at the same due
    times, their ratio, the 2σ-ellipse share."""
    tf, lat, lon = _once(*fixes)
    if tf.size < 3:
        return {}
    ne = np.array([plane.to_ne(a, b) for a, b in zip(lat, lon)])
    out = {}
    for h in HORIZONS:
        e_p, e_d, inside = [], [], []
        for p in est:
            if p.get("stale"):
                continue
            for row in p.get("predicted") or []:
                if abs(row.get("dt", -1) - h) > 0.05 or row.get("lat") is None:
                    continue
                t, due = p["t"], p["t"] + row["dt"]
                j = np.searchsorted(tf, due)
                if j == 0 or j >= tf.size or tf[j] - due > FIX_GAP or due - tf[j - 1] > FIX_GAP:
                    continue
                w = (due - tf[j - 1]) / (tf[j] - tf[j - 1]) if tf[j] > tf[j - 1] else 0.0
                truth = ne[j - 1] + w * (ne[j] - ne[j - 1])
                k = np.searchsorted(tf, t, side="right") - 1
                if k < 0:
                    continue
                v = _velocity(t, tf, ne, k, vel)
                if v is None:
                    continue
                dr = ne[k] + v * (due - tf[k])
                pred = np.array(plane.to_ne(row["lat"], row["lon"]))
                d = pred - truth
                e_p.append(float(d @ d))
                e_d.append(float((dr - truth) @ (dr - truth)))
                th = row.get("std_angle") or 0.0
                big, small = row.get("std_major"), row.get("std_minor")
                if big and small:
                    a = d[0] * math.cos(th) + d[1] * math.sin(th)
                    b = -d[0] * math.sin(th) + d[1] * math.cos(th)
                    inside.append((a / (2 * big)) ** 2 + (b / (2 * small)) ** 2 <= 1.0)
        if e_p:
            rp, rd = math.sqrt(np.mean(e_p)), math.sqrt(np.mean(e_d))
            out[h] = {"n": len(e_p), "rms": rp, "dr": rd, "ratio": rp / rd if rd > 0 else None,
                      "in_2sigma": float(np.mean(inside)) if inside else None}
    return out


def _once(tf: np.ndarray, lat: np.ndarray, lon: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The finite fixes, each once: a fix stamped with the last kept one's time, or equal
    to it and less than 0.9 s after it, is a repeat (GGA/RMC/GLL of one second; Aava's
    129029 repeating 129025's fix 0.5 s later), not where the vessel was at the later
    time. Kept, it makes the fixes lag the vessel, and dead reckoning from the repeat
    lags with them (Aava: the estimate 1.05x dead reckoning at 60 s; 1.00x without)."""
    keep: list[int] = []
    for i in range(tf.size):
        if not (math.isfinite(lat[i]) and math.isfinite(lon[i])):
            continue
        if keep:
            j = keep[-1]
            if tf[i] == tf[j] or (lat[i] == lat[j] and lon[i] == lon[j] and tf[i] - tf[j] < 0.9):
                continue
        keep.append(i)
    k = np.array(keep, dtype=int)
    return tf[k], lat[k], lon[k]


def _velocity(t: float, tf: np.ndarray, ne: np.ndarray, k: int, vel: tuple[np.ndarray, ...] | None) -> np.ndarray | None:
    """North/east velocity at t: the last SOG/COG, else the fixes' over the last 5 s."""
    if vel is not None:
        tv, sog, cog = vel
        i = np.searchsorted(tv, t, side="right") - 1
        if i >= 0 and np.isfinite(sog[i]) and np.isfinite(cog[i]):
            return np.array([sog[i] * math.cos(cog[i]), sog[i] * math.sin(cog[i])])
        if i >= 0:
            return None
    i0 = np.searchsorted(tf, tf[k] - 5.0, side="right") - 1
    if i0 < 0 or tf[k] - tf[i0] < 1.0:
        return None
    return (ne[k] - ne[i0]) / (tf[k] - tf[i0])


def catalogue(data: Path, listed_only: bool) -> dict[str, Log]:
    """manoeuvre_real's logs, then (unless `listed_only`) every other file under
    `data` (nmea0183/, n2k/) by the name after its repository prefix: a log the list
    leaves out (no heading, a format it does not feed) is still a log a user replays."""
    logs = {n: log for n, log in LOGS.items() if (data / log.path).is_file()}
    if listed_only:
        return logs
    known = {log.path for log in LOGS.values()}
    for f in sorted(p for d in ("nmea0183", "n2k") for p in (data / d).glob("*") if p.is_file()):
        rel = f"{f.parent.name}/{f.name}"
        if rel not in known:
            name = f.name.split("__")[-1].rsplit(".", 1)[0]
            logs.setdefault(name, Log(rel, "(not in manoeuvre_real.LOGS)", u_max=math.inf, v_max=math.inf))
    return logs


def analyse(name: str, log: Log, out: Path, reuse: bool, data: Path = DATA) -> dict[str, Any]:
    d = out / name
    res_file, said = d / "result.json", d / "replay.json"
    d.mkdir(parents=True, exist_ok=True)
    rec_path = d / "run.mcap"
    if reuse and said.exists():  # the replay is kept, the figures made afresh from its recording
        res: dict[str, Any] = json.loads(said.read_text())
    else:
        extra = ["--date", log.date] if log.date else []
        done = replay([data / log.path, *extra], rec_path, timeout=900)
        res = {"log": name, "path": log.path, "replay_rc": done.rc, "replay_said": done.stderr_tail if done.rc else ""}
        said.write_text(json.dumps(res))
    if not rec_path.exists():
        res_file.write_text(json.dumps(res))
        return res
    rec = read(rec_path, ["/health", "/est/manoeuvre", "/est/stw"], prefixes=["/meas/position/", "/meas/velocity_ground/",
                                                                                "/meas/heading/"])
    man = [p for p in rec.get("/est/manoeuvre") if not p.get("stale")]
    stw = [p for p in rec.get("/est/stw") if not p.get("stale")]
    pos, vg, hd = _by_source(rec, "position"), _by_source(rec, "velocity_ground"), _by_source(rec, "heading")
    res["sources"] = {"position": {k: len(v) for k, v in pos.items()}, "velocity_ground": {k: len(v) for k, v in vg.items()},
                      "heading": {k: len(v) for k, v in hd.items()}}
    res["estimates"] = {"manoeuvre": len(man), "stw": len(stw),
                        "manoeuvre_converging": sum(bool(p.get("converging")) for p in man),
                        "stw_converging": sum(bool(p.get("converging")) for p in stw)}
    gnss_sog = np.concatenate([_series(v, "sog")[1] for v in vg.values()]) if vg else np.zeros(0)
    gnss_sog = gnss_sog[np.isfinite(gnss_sog)]
    src = max(pos, key=lambda k: len(pos[k])) if pos else None
    fixes = _series(pos[src], "lat", "lon") if src else None
    fix_speed = None
    if fixes is not None and np.isfinite(fixes[1]).sum() >= 2:
        ok = np.isfinite(fixes[1])
        tf, la, lo = fixes[0][ok], fixes[1][ok], fixes[2][ok]
        plane = LocalPlane(float(la[0]), float(lo[0]))
        ne = np.array([plane.to_ne(a, b) for a, b in zip(la, lo)])
        sp = [float(np.hypot(*(ne[i] - ne[j])) / (tf[i] - tf[j])) for i in range(len(tf))
              for j in [int(np.searchsorted(tf, tf[i] - 10.0, side="right")) - 1] if j >= 0 and tf[i] - tf[j] >= 10.0]
        fix_speed = float(np.median(sp)) if sp else None
        vsrc = max(vg, key=lambda k: len(vg[k])) if vg else None
        vel = _series(vg[vsrc], "sog", "cog") if vsrc else None
        if vel is not None and not np.isfinite(vel[1]).any():
            vel = None
        res["prediction"] = {str(h): v for h, v in predictions(man, fixes, vel, plane).items()}
        res["prediction_source"] = src
        res["dr_velocity"] = vsrc if vel is not None else "fixes over 5 s"
    median_sog = float(np.median(gnss_sog)) if gnss_sog.size else fix_speed
    res["underway"] = bool(median_sog is not None and median_sog > 0.5)
    res["median_gnss_sog_kn"] = median_sog * KN if median_sog is not None else None
    res["berth"] = name in BERTH
    res["has_gnss"] = bool(pos)
    res["sog_max_kn"] = {
        "manoeuvre": max((p["sog"] for p in man if isinstance(p.get("sog"), (int, float))), default=None),
        "stw": max((p["sog"] for p in stw if isinstance(p.get("sog"), (int, float))), default=None),
        "gnss": float(gnss_sog.max()) if gnss_sog.size else None,
    }
    res["sog_max_kn"] = {k: (v * KN if v is not None else None) for k, v in res["sog_max_kn"].items()}
    te = np.array([p["t"] for p in man])
    he = np.array([p["heading"] if isinstance(p.get("heading"), (int, float)) else math.nan for p in man])
    res["heading"] = {}
    for s, ms in hd.items():
        t, h = _series(ms, "heading")
        i = np.searchsorted(te, t, side="right") - 1
        ok = (i >= 0) & np.isfinite(h)
        if te.size == 0 or not ok.any():
            continue
        diff = _wrap_deg((he[i[ok]] - h[ok]) * DEG)
        diff = diff[np.isfinite(diff)]
        if diff.size:
            res["heading"][s] = {"n": int(diff.size), "median": float(np.median(diff)),
                                 "rms": float(np.sqrt(np.mean(diff ** 2))), "src_median": float(np.median(h[ok]) * DEG)}
    res["stw"] = _stw_figures(stw)
    res["health"] = {}
    for e in ("manoeuvre", "stw"):
        hrows = health_of(rec.get("/health"), e)
        res["health"][e] = {"snapshots": len(hrows), "not_ok": sum(not ok for _, ok, _ in hrows),
                            "problems": problems_seen(hrows)}
    res_file.write_text(json.dumps(res))
    return res


def _stw_figures(stw: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The STW estimate against the log it reads (`dvl_stw`) and against SOG, its σ,
    and the log offset it found (median over the estimates after the first minute)."""
    if not stw:
        return None
    t0 = stw[0]["t"] + 60.0
    rows = [p for p in stw if p["t"] >= t0] or stw

    def med(key: str, f=lambda p, k: p.get(k)) -> float | None:
        xs = [f(p, key) for p in rows]
        xs = [x for x in xs if isinstance(x, (int, float)) and math.isfinite(x)]
        return float(np.median(xs)) if xs else None

    def diff(p: dict[str, Any], k: str) -> float | None:
        a, b = p.get("stw"), p.get(k)
        return a - b if isinstance(a, (int, float)) and isinstance(b, (int, float)) else None

    sd = [p.get("stw_std") for p in rows if isinstance(p.get("stw_std"), (int, float))]
    return {"minus_log": med("dvl_stw", diff), "minus_sog": med("sog", diff), "std_median": med("stw_std"),
            "std_max": max(sd) if sd else None, "dvl_bias": med("dvl_bias"), "first_std": stw[0].get("stw_std")}


def report(results: list[dict[str, Any]]) -> str:
    parts = []
    summary = []
    for r in results:
        name = r["log"]
        lines = [f"### {name}: {r.get('path')}",
                 f"replay rc {r['replay_rc']}{(' — ' + r['replay_said']) if r.get('replay_said') else ''}; "
                 f"underway {r.get('underway')} (median GNSS SOG {num(r.get('median_gnss_sog_kn'))} kn); "
                 f"berth {r.get('berth')}; estimates {r.get('estimates')}"]
        pr = r.get("prediction") or {}
        if pr:
            src, vs = str(r.get("prediction_source")), str(r.get("dr_velocity"))
            lines.append(f"prediction against the fixes of source {src.rsplit('.', 1)[-1]} (dead reckoning at the "
                         f"last SOG/COG of {vs.rsplit('.', 1)[-1] if '__' in vs else vs}):\n")
            lines.append(table(["horizon s", "n", "RMS m", "dead reckoning RMS m", "ratio", "in 2σ ellipse %"],
                               [[h, x["n"], num(x["rms"]), num(x["dr"]), num(x["ratio"], 2),
                                 f"{100 * x['in_2sigma']:.1f}" if x["in_2sigma"] is not None else "-"]
                                for h, x in pr.items()]))
        hd = r.get("heading") or {}
        if hd:
            lines.append("\nheading: estimate − source\n")
            lines.append(table(["source", "n", "source median °", "median °", "RMS °"],
                               [[s.rsplit(".", 1)[-1], x["n"], f"{x['src_median']:.1f}", f"{x['median']:+.2f}", num(x["rms"])]
                                for s, x in hd.items()]))
        sm = r.get("sog_max_kn") or {}
        hh = r.get("health") or {}
        st = r.get("stw") or {}
        if st:
            lines.append(f"\nstw (medians after the first minute): stw − log {num(st.get('minus_log'))} m/s, stw − sog "
                         f"{num(st.get('minus_sog'))} m/s, stw_std {num(st.get('std_median'))} (max "
                         f"{num(st.get('std_max'))}, first {num(st.get('first_std'))}), dvl_bias {num(st.get('dvl_bias'))}")
        lines.append(f"\nmax SOG kn: manoeuvre {num(sm.get('manoeuvre'))}, stw {num(sm.get('stw'))}, "
                     f"GNSS {num(sm.get('gnss'))}")
        for e, x in hh.items():
            lines.append(f"- health {e}: ok:false {x['not_ok']}/{x['snapshots']} snapshots; problems: {x['problems']}")
        parts.append("\n".join(lines))
        ratios = [num((pr.get(str(h)) or {}).get("ratio"), 2) for h in HORIZONS]
        cover = [(f"{100 * pr[str(h)]['in_2sigma']:.0f}" if pr.get(str(h)) and pr[str(h)]["in_2sigma"] is not None
                  else "-") for h in HORIZONS]
        worst_h = max((abs(x["median"]) for x in hd.values()), default=None)
        best_h = min((abs(x["median"]) for x in hd.values()), default=None)
        hm = hh.get("manoeuvre", {})
        st = r.get("stw") or {}
        stw_cell = (f"{num(st.get('minus_log'), 2)} / {num(st.get('minus_sog'), 2)} / "
                    f"{num(st.get('std_median'), 2)} (first {num(st.get('first_std'), 2)})") if st else "-"
        summary.append([name, "berth" if r.get("berth") else ("underway" if r.get("underway") else "still"),
                        num(r.get("median_gnss_sog_kn")), stw_cell,
                        r["replay_rc"], " / ".join(ratios), " / ".join(cover), num(sm.get("manoeuvre")),
                        num(sm.get("gnss")), f"{num(best_h)} / {num(worst_h)}" if hd else "-",
                        f"{hm.get('not_ok', 0)}/{hm.get('snapshots', 0)}", hm.get("problems", "-")])
    parts.insert(0, "### summary\n\n" + table(
        ["log", "state", "median GNSS SOG kn", "stw − log / stw − sog / stw_std median m/s", "replay rc",
         "pred/DR 10/30/60 s", "in 2σ % 10/30/60", "max SOG est kn", "max SOG GNSS kn",
         "|heading − source| median ° (closest / farthest source)", "manoeuvre ok:false", "manoeuvre problems"], summary))
    return "\n\n".join(parts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("logs", nargs="*", help=f"some of {', '.join(LOGS)} or of the other files' names "
                    "(default: every log present)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("real-logs-out"))
    ap.add_argument("--reuse", action="store_true", help="keep the replays already made (figures made afresh)")
    ap.add_argument("--data", type=Path, default=DATA, help=f"the logs' folder (default {DATA})")
    ap.add_argument("--listed", action="store_true", help="only manoeuvre_real.LOGS, not every file of --data")
    a = ap.parse_args()
    logs = catalogue(a.data, a.listed)
    names = a.logs or list(logs)
    unknown = [n for n in names if n not in logs]
    if unknown:
        sys.exit(f"no log {', '.join(unknown)} under {a.data} (there are {', '.join(logs)})")
    if not names:
        sys.exit(f"no log found under {a.data}")
    a.out.mkdir(parents=True, exist_ok=True)
    with ThreadPoolExecutor(max(1, a.jobs)) as ex:
        results = list(ex.map(lambda n: analyse(n, logs[n], a.out, a.reuse, a.data), names))
    # every log with GNSS fixes (its state says underway, still or berth), the berth ones in any case
    for r in results:
        r.setdefault("path", logs[r["log"]].path)
    chosen = [r for r in results if r.get("berth") or r.get("has_gnss")]
    others = [r["log"] for r in results if r not in chosen]
    text = "## real logs (default configuration)\n\n" + report(chosen)
    if others:
        text += f"\n\nreplayed, without GNSS fixes: {', '.join(others)}"
    (a.out / "real_logs.md").write_text(text + "\n")
    print(text)
    print(f"\nfiles in {a.out}/ (real_logs.md)")


if __name__ == "__main__":
    main()
