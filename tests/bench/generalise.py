"""Generalisation harness (issue 30): the default configuration over vessels × sensor
suites × seeds of the simulator, and under sensor faults. Run on demand, not in the
test suite; prints markdown tables and writes them, with every run's files, to --out.

    .venv/bin/python tests/bench/generalise.py [--vessels yacht,coaster,tanker]
        [--suites reference,coastal,yacht,mems,fog,sparse,two-compasses] [--seeds 1,2]
        [--duration 1800] [--warmup 120] [--jobs 2] [--out DIR] [--reuse]
    .venv/bin/python tests/bench/generalise.py --faults [accel-saturated,gap-6h,...] [--seeds 1]

Grid mode, per (vessel, suite, seed): `edged sim VESSEL:SUITE`, `edged replay
--no-zenoh --record` with the built-in default configuration, `edged score --json
--warmup W` (stale estimates left out by score). Per suite × vessel × field: the RMSE of
the estimate (RMS over seeds), of the best raw sensor of that field (score's baseline
rows: the lowest per seed, its topic named), their ratio, flagged `!` above 1.0; for
stw also the naive SOG − forecast (score's derived row) and the ratio to it; the share
inside ±3σ; and per run the share of estimates published `converging`, of health
snapshots with the estimator `ok: false`, and the problems health named. The summary
also gives the manoeuvre position and SOG at the GNSS's own instants (the first
estimate within 0.2 s after each fix) over the GNSS's there (`at_fixes`): with a fix
every 30 s the estimate at other times is a prediction, which no sensor gives.

Fault mode, per fault of the simulator (`edged_sim.grid.FAULTS`, run as the named
`fault-<name>` scenarios, or on --vessels × --suites when given): the window from
meta.json; for every field with a σ (and the position, σ the RMS of std.x, std.y): in
the window the share of estimates that are honest (|error| ≤ 3σ, or the estimator's
health `ok: false` at that time), the share flagged; the recovery time (after the
window, the first instant from which every field stays within 3σ for 60 s); the ±3σ
coverage outside the window (after the warm-up); the largest error in the window.

Deterministic given the code: the same arguments give the same tables.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from harness import display, edged, health_of, num, problems_seen, read, replay, table  # noqa: E402

from edged.estimates import ESTIMATE_KINDS  # noqa: E402
from edged_analysis.figures import field_errors, position_errors  # noqa: E402
from edged_analysis.recording import Recording  # noqa: E402
from edged_analysis.truth import load_truth  # noqa: E402
from edged_sim.grid import FAULTS  # noqa: E402
from edged_sim.suites import SUITES  # noqa: E402
from edged_sim.vessels import VESSELS  # noqa: E402

ESTIMATES = ("stw", "manoeuvre")
#: Fields shown, in this order (others that score gives follow).
ORDER = ("position", "stw", "stw_long", "stw_trans", "current_along", "current_set", "sog", "cog", "u", "v", "r",
         "heading", "drift_angle", "a_u", "a_v")
RECOVERED_FOR = 60.0  #: s within 3σ that count as recovered
K = 3.0


@dataclass(frozen=True)
class Job:
    scenario: str  #: edged sim's SCENARIO
    label: str  #: folder name
    seed: int
    duration: float | None


def run(job: Job, out: Path, warmup: float, reuse: bool) -> dict[str, Any]:
    """sim → replay → score for one job; the figures kept in `result.json`."""
    d = out / f"{job.label}-s{job.seed}"
    res_file = d / "result.json"
    if reuse and res_file.exists():
        res = json.loads(res_file.read_text())
        if job.label.startswith("fault") and (d / "run.mcap").exists():  # judged afresh: the judging may have changed
            res["fault"] = judge_fault(d, read(d / "run.mcap", ["/health"] + [f"/est/{e}" for e in ESTIMATES]), warmup)
        elif (d / "run.mcap").exists():
            res["at_fixes"] = at_fixes(d, warmup)
        return res
    d.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    args = ["sim", job.scenario, "--out", str(d), "--seed", str(job.seed)]
    sim = edged(*args, *(["--duration", str(job.duration)] if job.duration else []))
    res: dict[str, Any] = {"scenario": job.scenario, "label": job.label, "seed": job.seed, "sim_rc": sim.rc}
    if sim.rc != 0:
        res["error"] = f"sim: {sim.stderr_tail}"
        res_file.write_text(json.dumps(res))
        return res
    rec = d / "run.mcap"
    rp = replay([d / "nmea.log", d / "can.log"], rec, timeout=3600)
    res.update(replay_rc=rp.rc, replay_said=rp.stderr_tail if rp.rc else "")
    sc = edged("score", str(rec), "--truth", str(d / "truth.csv"), "--warmup", str(warmup), "--json")
    res["score"] = json.loads(sc.stdout) if sc.rc == 0 and sc.stdout.strip() else []
    if sc.rc != 0:
        res["score_error"] = sc.stderr_tail
    recorded = read(rec, ["/health"] + [f"/est/{e}" for e in ESTIMATES])
    res["health"] = {}
    for e in ESTIMATES:
        est = [p for p in recorded.get(f"/est/{e}") if not p.get("stale")]
        h = health_of(recorded.get("/health"), e)
        conv = [p for p in est if p.get("converging")]
        res["health"][e] = {
            "estimates": len(est), "converging": len(conv),
            "last_converging_s": (conv[-1]["t"] - est[0]["t"]) if conv else None,
            "not_ok": sum(not ok for _, ok, _ in h), "snapshots": len(h), "problems": problems_seen(h),
        }
    if job.label.startswith("fault"):
        res["fault"] = judge_fault(d, recorded, warmup)
    else:
        res["at_fixes"] = at_fixes(d, warmup)
    res["wall_s"] = round(time.monotonic() - t0, 1)
    res_file.write_text(json.dumps(res))
    return res


def at_fixes(d: Path, warmup: float) -> dict[str, dict[str, float]]:
    """The manoeuvre estimate at the GNSS's own instants: the first estimate within 0.2 s
    after each fix (or SOG/COG) of the busiest source, its error beside the fix's own.
    With a fix every 30 s the estimate between fixes is a prediction up to 30 s ahead,
    which no sensor gives; where the sensor speaks, this is like for like."""
    with (d / "truth.csv").open() as f:
        truth = load_truth(f, str(d / "truth.csv"))
    rec = read(d / "run.mcap", ["/est/manoeuvre"], prefixes=["/meas/position/", "/meas/velocity_ground/"])
    est = [p for p in rec.get("/est/manoeuvre") if not p.get("stale") and p.get("lat") is not None]
    if not est:
        return {}
    te = np.array([p["t"] for p in est])
    t_from = te[0] + warmup
    out: dict[str, dict[str, float]] = {}
    for kind, field in (("position", "position"), ("velocity_ground", "sog")):
        srcs = {k: v for k, v in rec.topics.items() if k.startswith(f"/meas/{kind}/")}
        if not srcs:
            continue
        meas = [p for p in max(srcs.values(), key=len) if p["t"] >= t_from]
        pairs = [(m, est[i]) for m in meas for i in [int(np.searchsorted(te, m["t"]))]
                 if i < len(est) and te[i] - m["t"] < 0.2]
        if not pairs:
            continue
        tm = np.array([m["t"] for m, _ in pairs])
        tp = np.array([e["t"] for _, e in pairs])
        if field == "position":
            em, _ = position_errors(truth, tm, np.array([m["lat"] for m, _ in pairs], dtype=float),
                                    np.array([m["lon"] for m, _ in pairs], dtype=float))
            ee, _ = position_errors(truth, tp, np.array([e["lat"] for _, e in pairs], dtype=float),
                                    np.array([e["lon"] for _, e in pairs], dtype=float))
        else:
            em, _ = field_errors(truth, "sog", tm, np.array([m.get("sog", math.nan) for m, _ in pairs], dtype=float))
            ee, _ = field_errors(truth, "sog", tp, np.array([e["sog"] for _, e in pairs], dtype=float))
        if em.size and ee.size:
            out[field] = {"sensor": float(np.sqrt(np.mean(em**2))), "estimate": float(np.sqrt(np.mean(ee**2))),
                          "n": int(ee.size)}
    return out


# -- grid tables ------------------------------------------------------------------------
def _rms(xs: list[float]) -> float | None:
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    return math.sqrt(sum(x * x for x in xs) / len(xs)) if xs else None


def grid_rows(results: list[dict[str, Any]]) -> dict[tuple[str, str, str, str], dict[str, Any]]:
    """Per (vessel:suite, estimate, field): estimate, best sensor, naive, over seeds."""
    acc: dict[tuple[str, str, str, str], dict[str, Any]] = {}
    for r in results:
        by: dict[tuple[str, str], dict[str, Any]] = {}
        for row in r.get("score", []):
            key = (row["estimate"], row["field"])
            b = by.setdefault(key, {"est": None, "sensor": None, "naive": None, "unit": row["unit"]})
            if row["baseline"] is None:
                b["est"] = row
            elif "naive" in row["baseline"]:
                if b["naive"] is None or row["rmse"] < b["naive"]["rmse"]:
                    b["naive"] = row
            elif row["rmse"] is not None and (b["sensor"] is None or row["rmse"] < b["sensor"]["rmse"]):
                b["sensor"] = row
        for (est, fld), b in by.items():
            if b["est"] is None:
                continue
            a = acc.setdefault((r["label"], est, fld, b["unit"]), {"est": [], "sensor": [], "naive": [], "cov": [],
                                                                     "sensor_topic": set()})
            a["est"].append(b["est"]["rmse"])
            a["cov"].append(b["est"].get("pct_3sigma"))
            if b["sensor"]:
                a["sensor"].append(b["sensor"]["rmse"])
                a["sensor_topic"].add(b["sensor"]["baseline"].rsplit("/", 1)[-1])
            if b["naive"]:
                a["naive"].append(b["naive"]["rmse"])
    return acc


def _order(fld: str) -> tuple[int, str]:
    return (ORDER.index(fld) if fld in ORDER else len(ORDER), fld)


#: The summary's columns: (estimate, field), each shown as the ratio to its best sensor.
SUMMARY = (("manoeuvre", "position"), ("manoeuvre", "sog"), ("manoeuvre", "cog"), ("manoeuvre", "r"),
           ("manoeuvre", "heading"), ("stw", "sog"), ("stw", "stw"))


def summary(acc: dict[tuple[str, str, str, str], dict[str, Any]], vessels: list[str], suites: list[str],
            results: list[dict[str, Any]]) -> str:
    """One row per suite × vessel: each field's ratio to its best sensor (`!` above
    1.0, `-` when the estimator published nothing), stw against the naive, and the
    manoeuvre position and SOG at the GNSS's own instants against the GNSS (`at_fixes`)."""
    rows = []
    for suite in suites:
        for vessel in vessels:
            label = f"{vessel}-{suite}"
            cells = [suite, vessel]
            for est, fld in SUMMARY:
                a = next((v for k, v in acc.items() if k[:3] == (label, est, fld)), None)
                e, sn = (_rms(a["est"]), _rms(a["sensor"])) if a else (None, None)
                ratio = e / sn if e is not None and sn else None
                cells.append("-" if ratio is None else f"{ratio:.2f}{' !' if ratio > 1.0 else ''}")
            a = next((v for k, v in acc.items() if k[:3] == (label, "stw", "stw")), None)
            e, n = (_rms(a["est"]), _rms(a["naive"])) if a else (None, None)
            cells += [num(e), num(n), "-" if not n or e is None else f"{e / n:.2f}"]
            for fld in ("position", "sog"):
                fx = [r["at_fixes"][fld] for r in results if r["label"] == label and fld in (r.get("at_fixes") or {})]
                es, ss = _rms([x["estimate"] for x in fx]), _rms([x["sensor"] for x in fx])
                cells.append("-" if not es or not ss else f"{es / ss:.2f}{' !' if es > ss else ''}")
            rows.append(cells)
    head = ["suite", "vessel"] + [f"{e}.{f} /sensor" for e, f in SUMMARY] + [
        "stw RMSE m/s", "naive m/s", "stw/naive", "position /fix at the fixes", "sog /GNSS at the fixes"]
    return "### summary: each field's RMSE over its best raw sensor's\n\n" + table(head, rows)


def grid_report(results: list[dict[str, Any]], vessels: list[str], suites: list[str]) -> str:
    acc = grid_rows(results)
    parts = [summary(acc, vessels, suites, results)]
    flagged = []
    for suite in suites:
        rows = []
        for vessel in vessels:
            label = f"{vessel}-{suite}"
            keys = sorted((k for k in acc if k[0] == label), key=lambda k: (k[1], _order(k[2])))
            for key in keys:
                _, est, fld, unit = key
                a = acc[key]
                e, s, n = _rms(a["est"]), _rms(a["sensor"]), _rms(a["naive"])
                ratio = e / s if e is not None and s else None
                flag = "!" if ratio is not None and ratio > 1.0 else ""
                if flag:
                    flagged.append(f"{suite} × {vessel}: {est}.{fld} {ratio:.2f}× its sensor")
                ev, u = display(e, unit)
                sv, _ = display(s, unit)
                nv, _ = display(n, unit)
                covs = [c for c in a["cov"] if c is not None]
                rows.append([vessel, f"{est}.{fld}", u, num(ev), num(sv) + (f" ({'/'.join(sorted(a['sensor_topic']))})"
                             if s is not None else ""), (num(ratio, 2) + " " + flag).strip() if ratio else "-",
                             num(nv) if n is not None else "", num(e / n, 2) if n and e is not None else "",
                             f"{sum(covs) / len(covs):.1f}" if covs else "-"])
        parts.append(f"### suite `{suite}`: {SUITES[suite].description}\n\n" + table(
            ["vessel", "field", "unit", "RMSE", "sensor RMSE (best source)", "ratio", "naive", "/naive", "in ±3σ %"],
            rows))
    runs = []
    for r in sorted(results, key=lambda r: (r["label"], r["seed"])):
        hs = r.get("health", {})
        cells = [r["label"], r["seed"], r.get("replay_rc", "-"), r.get("wall_s", "-")]
        for e in ESTIMATES:
            h = hs.get(e, {})
            n = h.get("estimates") or 0
            cells += [f"{n} ({100 * h.get('converging', 0) / n:.1f} %)" if n else "0",
                      f"{100 * h['not_ok'] / h['snapshots']:.0f} %" if h.get("snapshots") else "-",
                      h.get("problems", "-")]
        runs.append(cells + [r.get("error") or r.get("score_error") or r.get("replay_said") or ""])
    parts.append("### runs: converging, health\n\n" + table(
        ["run", "seed", "replay rc", "wall s", "stw estimates (converging)", "stw ok:false", "stw problems",
         "manoeuvre estimates (converging)", "manoeuvre ok:false", "manoeuvre problems", "errors"], runs))
    parts.append("### ratios above 1.0 (a field worse than its own sensor)\n\n"
                 + ("\n".join(f"- {f}" for f in flagged) if flagged else "none"))
    return "\n\n".join(parts)


# -- faults -----------------------------------------------------------------------------
def _window(meta: dict[str, Any]) -> tuple[float, float] | None:
    spans = [(w["start_s"], w["end_s"]) for w in meta["faults"]["windows"]]
    spans += [(j["start_s"], j["end_s"]) for j in meta["faults"]["position_jumps"]]
    if not spans:
        return None
    t0 = meta["start_time"]
    return t0 + min(a for a, _ in spans), t0 + max(b for _, b in spans)


def _errors(rec: Recording, truth, name: str, payloads: list[dict[str, Any]]) -> dict[str, tuple[np.ndarray, ...]]:
    """Per field with a σ: (t, error, σ) of the non-stale estimates, angles wrapped."""
    out: dict[str, tuple[np.ndarray, ...]] = {}
    for (n, kind), series in rec.estimates.items():
        if n != name:
            continue
        c = series.columns()
        keep = ~c.stale
        t = c.t[keep]
        for f in ESTIMATE_KINDS[kind].scored_fields():
            if not f.std or f.truth not in truth.columns:
                continue
            err, idx = field_errors(truth, f.truth, t, c.values[f.path][keep], f.angle)
            out[f.path] = (t[idx], err, c.values[f.std][keep][idx])
        if "lat" in c.values:
            live = [p for p in payloads if not p.get("stale")]
            sx = np.array([((p.get("std") or {}).get("x") or math.nan) for p in live], dtype=float)
            sy = np.array([((p.get("std") or {}).get("y") or math.nan) for p in live], dtype=float)
            tp = np.array([p["t"] for p in live])
            lat = np.array([p.get("lat") if p.get("lat") is not None else math.nan for p in live], dtype=float)
            lon = np.array([p.get("lon") if p.get("lon") is not None else math.nan for p in live], dtype=float)
            err, idx = position_errors(truth, tp, lat, lon)
            out["position"] = (tp[idx], err, np.sqrt(0.5 * (sx[idx] ** 2 + sy[idx] ** 2)))
    return out


def judge_fault(d: Path, recorded, warmup: float) -> dict[str, Any]:
    meta = json.loads((d / "meta.json").read_text())
    win = _window(meta)
    with (d / "truth.csv").open() as f:
        truth = load_truth(f, "truth.csv")
    rec = Recording(str(d))
    for e in ESTIMATES:
        for p in recorded.get(f"/est/{e}"):
            rec.add(f"/est/{e}", p)
    out: dict[str, Any] = {"window": win}
    if win is None:
        return out
    a, b = win
    for e in ESTIMATES:
        payloads = recorded.get(f"/est/{e}")
        if not payloads:
            continue
        h = health_of(recorded.get("/health"), e)
        ht = np.array([x[0] for x in h]) if h else np.zeros(0)
        hbad = np.array([not x[1] for x in h]) if h else np.zeros(0, bool)
        start = payloads[0]["t"] + warmup
        fields = {}
        for fld, (t, err, sig) in _errors(rec, truth, e, payloads).items():
            if t.size == 0:
                continue
            within = np.abs(err) <= K * sig  # NaN σ: not within
            j = np.searchsorted(ht, t, side="right") - 1
            flagged = np.where(j >= 0, hbad[np.clip(j, 0, None)] if hbad.size else False, False)
            ins = (t >= a) & (t <= b)
            outside = ((t < a) | (t > b)) & (t >= start)
            after = t > b
            rec_s = None
            if after.any():
                ta, wa = t[after], within[after]
                bad = np.flatnonzero(~wa)
                # the first instant after the last failure that is followed by RECOVERED_FOR s within 3σ
                cand = [ta[0]] + [ta[i + 1] for i in bad if i + 1 < ta.size]
                for c in cand:
                    span = (ta >= c) & (ta < c + RECOVERED_FOR)
                    if ta[-1] >= c + RECOVERED_FOR and wa[span].all():
                        rec_s = float(c - b)
                        break
            fields[fld] = {
                "n_in": int(ins.sum()),
                "honest_in": float(np.mean(within[ins] | flagged[ins])) if ins.any() else None,
                "flagged_in": float(np.mean(flagged[ins])) if ins.any() else None,
                "max_err_in": float(np.max(np.abs(err[ins]))) if ins.any() else None,
                "sigma_at_max": float(sig[ins][np.argmax(np.abs(err[ins]))]) if ins.any() else None,
                "recovery_s": rec_s,
                "coverage_out": float(np.mean(within[outside])) if outside.any() else None,
            }
        out[e] = {"fields": fields, "problems": problems_seen([x for x in h if a <= x[0] <= b + 600.0])}
        if e == "stw":
            out[e]["dvl_bias"] = _dvl_bias(payloads, meta, b)
    return out


def _dvl_bias(payloads: list[dict[str, Any]], meta: dict[str, Any], end: float) -> str:
    """The log offset the estimate states (± σ) at the window's end and at the run's
    end, beside the simulated one (truth.csv has no column for it)."""
    sim = next((s["bias"].get("stw_long") for s in meta["sensors"] if s["model"] == "water_speed"), None)

    def at(t: float) -> str:
        p = next((p for p in reversed(payloads) if p["t"] <= t and not p.get("stale")), None)
        if p is None or not isinstance(p.get("dvl_bias"), (int, float)):
            return "null"
        sd = (p.get("dvl_std") or {}).get("bias")
        return f"{p['dvl_bias']:+.2f}" + (f" ± {sd:.2f}" if isinstance(sd, (int, float)) else "")

    if sim is None:
        return "-"
    return f"dvl_bias {at(end)} at the window's end, {at(payloads[-1]['t'])} at the end (simulated {sim:+.2f} m/s)"


def fault_report(results: list[dict[str, Any]]) -> str:
    rows = []
    for r in sorted(results, key=lambda r: (r["label"], r["seed"])):
        f = r.get("fault") or {}
        for e in ESTIMATES:
            fe = f.get(e)
            if not fe:
                continue
            for fld in sorted(fe["fields"], key=_order):
                x = fe["fields"][fld]
                unit = {"heading": "rad", "r": "rad/s"}.get(fld, "")
                mx, u = display(x["max_err_in"], unit)
                sg, _ = display(x["sigma_at_max"], unit)
                rows.append([r["label"], r["seed"], r.get("replay_rc"), f"{e}.{fld}",
                             f"{100 * x['honest_in']:.0f}" if x["honest_in"] is not None else "-",
                             f"{100 * x['flagged_in']:.0f}" if x["flagged_in"] is not None else "-",
                             f"{num(mx)} (σ {num(sg)}) {u}".strip(),
                             "never" if x["recovery_s"] is None else f"{x['recovery_s']:.0f}",
                             f"{100 * x['coverage_out']:.1f}" if x["coverage_out"] is not None else "-",
                             (fe["problems"] + (f"; {fe['dvl_bias']}" if fe.get("dvl_bias") else ""))
                             if fld == sorted(fe["fields"], key=_order)[0] else ""])
    return table(["fault run", "seed", "replay rc", "field", "honest in window %", "ok:false in window %",
                  "max |err| in window", "recovery s", "±3σ outside %", "problems named (window + 10 min)"], rows)


def _list(text: str | None, table_: dict, what: str) -> list[str]:
    if text is None:
        return list(table_)
    names = [x for x in text.split(",") if x]
    bad = [n for n in names if n not in table_]
    if bad:
        sys.exit(f"no {what} {', '.join(bad)} (there are {', '.join(table_)})")
    return names


def _seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vessels", help=f"comma-separated, of {', '.join(VESSELS)} (default all)")
    ap.add_argument("--suites", help=f"comma-separated, of {', '.join(SUITES)} (default all)")
    ap.add_argument("--seeds", default="1", help="e.g. 1,2 or 1-5 (default 1)")
    ap.add_argument("--duration", type=float, default=1800.0, help="s of each grid run (default 1800; faults: theirs)")
    ap.add_argument("--warmup", type=float, default=120.0, help="s after the first estimate left out (default 120)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None, help="folder for the runs and tables (default ./generalise-out)")
    ap.add_argument("--reuse", action="store_true", help="keep runs whose result.json exists")
    ap.add_argument("--faults", nargs="?", const="", default=None, metavar="NAMES",
                    help=f"fault mode: some of {', '.join(FAULTS)} (default all)")
    a = ap.parse_args()
    out = a.out or Path("generalise-out")
    out.mkdir(parents=True, exist_ok=True)
    seeds = _seeds(a.seeds)
    if a.faults is not None:
        faults = _list(a.faults or None, FAULTS, "fault")
        if a.vessels or a.suites:
            combos = [(v, s) for v in _list(a.vessels, VESSELS, "vessel") for s in _list(a.suites, SUITES, "suite")]
            jobs = [Job(f"{v}:{s}:{f}", f"fault-{f}-{v}-{s}", seed, None) for f in faults for v, s in combos
                    for seed in seeds]
        else:
            jobs = [Job(f"fault-{f}", f"fault-{f}", seed, None) for f in faults for seed in seeds]
    else:
        vessels, suites = _list(a.vessels, VESSELS, "vessel"), _list(a.suites, SUITES, "suite")
        jobs = [Job(f"{v}:{s}", f"{v}-{s}", seed, a.duration) for s in suites for v in vessels for seed in seeds]
    t0 = time.monotonic()
    with ThreadPoolExecutor(max(1, a.jobs)) as ex:
        results = list(ex.map(lambda j: run(j, out, a.warmup, a.reuse), jobs))
    if a.faults is not None:
        text = "## faults (default configuration)\n\n" + fault_report(results)
    else:
        head = f"## generalisation grid ({a.duration:g} s runs, seeds {a.seeds}, scored after {a.warmup:g} s)"
        text = head + "\n\n" + grid_report(results, vessels, suites)
    name = "faults.md" if a.faults is not None else "grid.md"
    (out / name).write_text(text + "\n")
    print(text)
    print(f"\n{len(jobs)} runs in {time.monotonic() - t0:.0f} s; files in {out}/ ({name})")


if __name__ == "__main__":
    main()
