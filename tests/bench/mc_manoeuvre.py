"""Monte-Carlo harness of the manoeuvring-state estimator (issue 13; seed 002 §4–§5).

Run (on demand, not part of the test suite; prints tables):

    .venv/bin/python tests/bench/mc_manoeuvre.py [--scenario manoeuvre-williamson] [--runs 50]
        [--combos ctra+ekf,ctra+ukf,ctra+enkf,cmm+ukf,cmm+ekf] [--jobs 2] [--out DIR]
        [--mode tuned|paper] [--warmup 30] [--north] [--predict] [--quick]

Why: the paper judges a filter by N runs of one voyage with different sensor noise and
initial errors: the share of steps whose N-run average NIS lies in its χ² 95 % band
(Table 4), the share whose N-run average autocorrelation of the innovations between
consecutive steps lies in ±1.96/√N (eq. 26, Table 5), the RMS error per state over the
runs (eq. 27) and the divergences; per voyage segment (S1–S6 of §5.1). This script makes
those tables for our estimator core (`edged_manoeuvre.core.ManoeuvreCore`) on the
simulator's scenarios, beside the paper's figures.

How:
- Run j: `edged sim <scenario> --seed j` (other sensor noise), cached in
  `--out/<scenario>-<j>/` with a pickle of the decoded measurements (`ms.pkl`, decoded
  as `edged replay` does: `tests/support/manoeuvre_data.measurements`); the core starts
  from an initial error drawn from P0 (`init_rng = default_rng(1000 + j)`, seed 002
  eq. 13); an EnKF's member seed is j.
- One source per kind (`SOURCES`), printed with what the logs hold. The core is fed in
  time order and ticked on the 0.1 s data-time grid before each measurement (the worker
  host with publish_rate 10).
- A step is 0.1 s of data time. (a) pools every update in the step, all kinds: ΣNIS over
  runs against the χ² band of Σdof (the band of the average is that divided by N).
  (b) per kind (position, heading): the whitened innovation of the step's last update
  (L⁻¹y, S = LLᵀ), eq. 26 between step k and k+1 over the runs holding both. Eq. 26
  divides by √dim(z), which for the 2-D position makes its spread 1/(2√N) and the test
  twice as lenient; "pos√d" is the same statistic scaled to a spread of 1/√N under H0.
  (c) RMS over the runs per step of each state's error at the ticks, mean over the
  segment's steps. Every table counts only steps after `--warmup` s.
- `--north` (zigzag): the same scenario with the zigzag's base heading and start heading
  turned by 180° (built in-process with `dataclasses.replace`; the same seeds) and, per
  crossing of north by the true heading, the NIS and RMS errors within ±10 s of it in
  both runs: a filter that handles north shows no difference.
- `--predict`: each estimate whose `predicted` rows were made at its tick (row dt equal to
  the horizons) against truth at t+dt, beside dead reckoning (the latest GNSS fix moved
  along the latest SOG/COG to t+dt); split by |true r(t)| > 0.1°/s ("turning"); with the
  share of truths inside the published 1-σ ellipse (39.3 % nominal) and 2σ (86.5 %).
Deterministic: the same arguments give the same tables (CPU times aside).
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one core per job: the matrices are 8 × 8

import argparse
import dataclasses
import functools
import logging
import math
import multiprocessing
import pickle
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "support"))

from manoeuvre_data import measurements, select  # noqa: E402

from edged.innovation import chi2_band  # noqa: E402
from edged_manoeuvre.config import ManoeuvreConfig  # noqa: E402
from edged_manoeuvre.core import ManoeuvreCore  # noqa: E402
from edged_analysis.truth import load_truth  # noqa: E402

DEG = math.pi / 180.0
COMBOS = ("ctra+ekf", "ctra+ukf", "ctra+enkf", "cmm+ukf", "cmm+ekf")
#: Source per kind: the NMEA GNSS for position and heading, the IMU for rate and accelerations.
SOURCES = {"position": "nmea", "heading": "nmea", "yaw_rate": "can0.ImuRate", "accel_body": "can0.ImuAccel"}
#: Dead reckoning takes SOG/COG from the same receiver as the fix.
DR_SOURCE = "nmea"
STATES = ("u", "v", "r", "heading", "a_u", "a_v", "pos")
UNITS = {"u": "m/s", "v": "m/s", "r": "°/s", "heading": "°", "a_u": "m/s²", "a_v": "m/s²", "pos": "m"}
AC_KINDS = (("position", 2), ("heading", 1))
#: The kinds of update in `core.trace`, for the NIS per kind.
NIS_KINDS = ("position", "heading", "yaw_rate", "accel")
ROT = "-rot180"  # suffix of the rotated zigzag's key

#: Seed 002, Tables 4 and 5 (S1..S6), for reference.
PAPER = {
    "cmm+ukf": ((77, 77, 67, 80, 77, 72), (94, 95, 81, 93, 93, 95)),
    "ctra+ekf": ((73, 80, 74, 77, 77, 74), (92, 94, 92, 96, 96, 95)),
    "ctra+ukf": ((73, 80, 74, 77, 77, 74), (93, 94, 93, 95, 93, 95)),
}

# WGS-84, for metres between two nearby positions.
_A, _E2 = 6378137.0, 6.69437999014e-3


def metres(lat: np.ndarray, lon: np.ndarray, lat0: np.ndarray, lon0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(north, east) in m of (lat, lon) from (lat0, lon0), degrees; fine within kilometres."""
    phi = np.radians(lat0)
    s2 = 1.0 - _E2 * np.sin(phi) ** 2
    m = _A * (1.0 - _E2) / s2**1.5
    n = _A / np.sqrt(s2)
    return np.radians(lat - lat0) * m, np.radians(lon - lon0) * n * np.cos(phi)


@functools.lru_cache(maxsize=None)
def band(dof: int) -> tuple[float, float]:
    return chi2_band(int(dof))


# ---------------------------------------------------------------- scenarios and cache
def rotated_scenario(name: str) -> Any:
    """`name` (a zigzag) with its base heading and start heading turned by 180°."""
    from edged_sim.helm import ZigZag
    from edged_sim.scenarios import SCENARIOS

    s = SCENARIOS[name]
    if not isinstance(s.helm, ZigZag):
        raise SystemExit(f"--north needs a zigzag scenario; {name} is not one")
    return dataclasses.replace(
        s, name=name + ROT, description=s.description + ", turned by 180°",
        helm=dataclasses.replace(s.helm, base_heading_deg=(s.helm.base_heading_deg + 180.0) % 360.0),
        heading_deg=(s.heading_deg + 180.0) % 360.0,
    )


def prepare(task: tuple[str, int, str]) -> str:
    """Simulate run `seed` of `key` into the cache (unless there) and decode it to ms.pkl."""
    key, seed, out = task
    d = Path(out) / f"{key}-{seed}"
    pkl = d / "ms.pkl"
    if pkl.exists():
        return str(d)
    if not (d / "meta.json").exists():
        if key.endswith(ROT):
            from edged_sim.run import Simulation
            from edged_sim.writers import write_run

            write_run(Simulation(rotated_scenario(key[: -len(ROT)]), seed=seed), d)
        else:
            subprocess.run([sys.executable, "-m", "edged.cli", "sim", key, "--out", str(d), "--seed", str(seed)],
                           check=True, stdout=subprocess.DEVNULL)
    logs = [p for p in (d / "nmea.log", d / "can.log") if p.exists()]
    ms = measurements(logs)
    tmp = pkl.with_suffix(".tmp")
    with open(tmp, "wb") as f:
        pickle.dump(ms, f, protocol=pickle.HIGHEST_PROTOCOL)
    tmp.replace(pkl)
    return str(d)


def load_ms(d: str) -> list:
    with open(Path(d) / "ms.pkl", "rb") as f:
        return pickle.load(f)


def load_truth_dir(d: str) -> Any:
    with open(Path(d) / "truth.csv", encoding="ascii") as f:
        return load_truth(f, "truth")


# ---------------------------------------------------------------- one run
def run_one(task: dict) -> dict:
    """Feed run `task['seed']` through one model/filter; per-step arrays for the tables."""
    logging.getLogger("edged").setLevel(logging.CRITICAL)
    d, seed = task["dir"], task["seed"]
    model, filt = task["combo"].split("+")
    truth = load_truth_dir(d)
    t0 = float(truth.t[0])
    K = len(truth.t) + 1
    ms = load_ms(d)
    feed = select(ms, list(SOURCES) + ["velocity_ground"], {**SOURCES, "velocity_ground": DR_SOURCE})
    del ms
    cfg = ManoeuvreConfig(type="manoeuvre", model=model, filter=filt, mode=task["mode"], seed=seed,
                          **task.get("set", {}))
    core = ManoeuvreCore(cfg, init_rng=np.random.default_rng(1000 + seed))
    core.trace = []
    out = []
    fresh = []  # (t, rows, fix (t, lat, lon), vg (t, sog, cog)) at ticks with a fresh prediction
    horizons = [float(h) for h in cfg.horizons]
    fix = vg = None
    nxt = None
    n_fed = 0
    cpu0 = time.process_time()
    for m in feed:
        if nxt is None:
            nxt = math.floor(m.t * 10) / 10 + 0.1
        while m.t >= nxt - 1e-9:
            for e in core.tick(nxt):
                out.append(e)
                rows = e.values.get("predicted") or []
                if task["predict"] and rows and [r["dt"] for r in rows] == horizons and fix and vg:
                    fresh.append((e.t, rows, fix, vg))
            nxt = round(nxt + 0.1, 6)
        if m.kind == "velocity_ground":
            vg = (m.t, m.values.get("sog"), m.values.get("cog"))
            continue
        if m.kind == "position":
            fix = (m.t, m.values.get("lat"), m.values.get("lon"))
        core.step(m)
        n_fed += 1
    cpu = time.process_time() - cpu0

    # (a), (b): per step, from the trace
    nis = np.zeros(K)
    dof = np.zeros(K)
    white = {k: np.full((K, dim), np.nan) for k, dim in AC_KINDS}
    kind_nis = np.zeros((K, len(NIS_KINDS), 2))  # ΣNIS, Σdof per kind
    bad_nis = 0
    for t, kind, n_, d_, _applied, w in core.trace:
        k = int(math.floor((t - t0) * 10.0 + 1e-4))
        if not 0 <= k < K:
            continue
        if not math.isfinite(n_):
            bad_nis += 1
            continue
        nis[k] += n_
        dof[k] += d_
        if kind in NIS_KINDS:
            kind_nis[k, NIS_KINDS.index(kind)] += (n_, d_)
        if kind in white and w.shape == (white[kind].shape[1],):
            white[kind][k] = w

    # (c): errors at the ticks
    err = np.full((K, len(STATES)), np.nan)
    nan_est = 0
    if out:
        te = np.array([e.t for e in out])
        idx = np.rint((te - t0) * 10.0).astype(int)
        ok = (idx >= 0) & (idx < K)
        cols = {}
        for i, f in enumerate(STATES[:-1]):
            est = np.array([float(e.values[f]) for e in out])
            tr = truth.at(f, te, 2 * math.pi if f == "heading" else None)
            x = est - tr
            if f == "heading":
                x = (x + math.pi) % (2 * math.pi) - math.pi
            if f in ("r", "heading"):
                x = x / DEG
            cols[i] = x
        lat = np.array([float(e.values["lat"]) for e in out])
        lon = np.array([float(e.values["lon"]) for e in out])
        dn, de = metres(lat, lon, truth.at("lat", te), truth.at("lon", te))
        cols[len(STATES) - 1] = np.hypot(dn, de)
        for i, x in cols.items():
            nan_est += int(np.sum(~np.isfinite(x) & ok))
            err[idx[ok], i] = x[ok]

    # raw sensors against truth, for reference (after the warm-up)
    raw = {}
    warm = task["warmup"]
    by_kind: dict[str, list] = {}
    for m in feed:
        if m.t - t0 > warm:
            by_kind.setdefault(m.kind, []).append(m)
    if by_kind.get("yaw_rate"):
        tt = np.array([m.t for m in by_kind["yaw_rate"]])
        raw["r"] = (np.array([m.values["r"] for m in by_kind["yaw_rate"]]) - truth.at("r", tt)) / DEG
    if by_kind.get("heading"):
        tt = np.array([m.t for m in by_kind["heading"]])
        x = np.array([m.values["heading"] for m in by_kind["heading"]]) - truth.at("heading", tt, 2 * math.pi)
        raw["heading"] = ((x + math.pi) % (2 * math.pi) - math.pi) / DEG
    if by_kind.get("position"):
        tt = np.array([m.t for m in by_kind["position"]])
        dn, de = metres(np.array([m.values["lat"] for m in by_kind["position"]]),
                        np.array([m.values["lon"] for m in by_kind["position"]]),
                        truth.at("lat", tt), truth.at("lon", tt))
        raw["pos"] = np.hypot(dn, de)
    raw_sq = {k: (float(np.nansum(v**2)), int(np.sum(np.isfinite(v)))) for k, v in raw.items()}

    # prediction against truth and dead reckoning
    pred = np.zeros((0, 6))
    if fresh:
        recs = []
        for t, rows, (tf, flat, flon), (_tv, sog, cog) in fresh:
            for hi, row in enumerate(rows):
                recs.append((t, hi, row["dt"], row["lat"], row["lon"], row["std_major"], row["std_minor"],
                             row["std_angle"], tf, flat, flon, sog if sog is not None else np.nan,
                             cog if cog is not None else np.nan))
        a = np.array(recs, dtype=float)
        t, hi, dt = a[:, 0], a[:, 1], a[:, 2]
        tl, lat_t, lon_t = t + dt, truth.at("lat", t + dt), truth.at("lon", t + dt)
        r_true = truth.at("r", t)
        dn, de = metres(lat_t, lon_t, a[:, 3], a[:, 4])  # truth − predicted
        e_model = np.hypot(dn, de)
        th = a[:, 7]
        along = dn * np.cos(th) + de * np.sin(th)
        across = -dn * np.sin(th) + de * np.cos(th)
        m2 = (along / np.maximum(a[:, 5], 1e-9)) ** 2 + (across / np.maximum(a[:, 6], 1e-9)) ** 2
        fn, fe = metres(lat_t, lon_t, a[:, 9], a[:, 10])  # truth − fix
        run_dr = a[:, 11] * (tl - a[:, 8])
        e_dr = np.hypot(fn - run_dr * np.cos(a[:, 12]), fe - run_dr * np.sin(a[:, 12]))
        keep = np.isfinite(lat_t) & (t - t0 > warm)
        pred = np.column_stack([hi, np.abs(r_true) > 0.1 * DEG, e_model, e_dr, m2, t - t0])[keep]

    h = core.health()
    return {
        "key": task["key"], "combo": task["combo"], "seed": seed, "t0": t0, "K": K,
        "nis": nis, "dof": dof, "kind_nis": kind_nis, "white": white, "err": err, "pred": pred, "raw": raw_sq,
        "divergences": int(core.divergences), "cpu": cpu, "updates": len(core.trace), "fed": n_fed,
        "nan_est": nan_est, "bad_nis": bad_nis, "estimates": len(out),
        "events": dict(h.get("events", {})), "rejected": dict(h.get("rejected", {})),
    }


# ---------------------------------------------------------------- accumulation
class Acc:
    """Sums over runs of one (scenario, combo), step by step."""

    def __init__(self, K: int) -> None:
        self.K = K
        self.n = 0
        self.nis = np.zeros(K)
        self.dof = np.zeros(K)
        self.kind_nis = np.zeros((K, len(NIS_KINDS), 2))
        self.ac = {k: [np.zeros(K - 1) for _ in range(4)] for k, _ in AC_KINDS}  # num, den1², den2², runs
        self.sq = np.zeros((K, len(STATES)))
        self.cnt = np.zeros((K, len(STATES)))
        self.div = 0
        self.cpu = 0.0
        self.updates = 0
        self.fed = 0
        self.nan_est = 0
        self.bad_nis = 0
        self.preds: list[np.ndarray] = []
        self.raw: dict[str, list[float]] = {}
        self.events: Counter = Counter()
        self.rejected: Counter = Counter()
        self.per_run_div: list[int] = []

    def add(self, r: dict) -> None:
        self.n += 1
        self.nis += r["nis"]
        self.dof += r["dof"]
        self.kind_nis += r["kind_nis"]
        for k, _ in AC_KINDS:
            w = r["white"][k]
            a, b = w[:-1], w[1:]
            both = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
            num, d1, d2, c = self.ac[k]
            num[both] += np.sum(a[both] * b[both], axis=1)
            d1[both] += np.sum(a[both] ** 2, axis=1)
            d2[both] += np.sum(b[both] ** 2, axis=1)
            c[both] += 1
        e = r["err"]
        ok = np.isfinite(e)
        self.sq[ok] += e[ok] ** 2
        self.cnt += ok
        self.div += r["divergences"]
        self.per_run_div.append(r["divergences"])
        self.cpu += r["cpu"]
        self.updates += r["updates"]
        self.fed += r["fed"]
        self.nan_est += r["nan_est"]
        self.bad_nis += r["bad_nis"]
        if len(r["pred"]):
            self.preds.append(r["pred"])
        for k, (s, n) in r["raw"].items():
            v = self.raw.setdefault(k, [0.0, 0])
            v[0] += s
            v[1] += n
        self.events.update(r["events"])
        self.rejected.update(r["rejected"])

    # per-step statistics
    def nis_state(self) -> np.ndarray:
        """Per step: -1 below the band, 0 inside, +1 above, NaN without updates."""
        s = np.full(self.K, np.nan)
        for k in np.nonzero(self.dof > 0)[0]:
            lo, hi = band(int(round(self.dof[k])))
            s[k] = -1.0 if self.nis[k] < lo else (1.0 if self.nis[k] > hi else 0.0)
        return s

    def ac_inside(self, kind: str, scaled: bool) -> np.ndarray:
        """Per step k (pair k, k+1): 1 inside ±1.96/√N, 0 outside, NaN without pairs."""
        dim = dict(AC_KINDS)[kind]
        num, d1, d2, c = self.ac[kind]
        out = np.full(self.K, np.nan)
        ok = (c > 0) & (d1 > 0) & (d2 > 0)
        rho = num[ok] / np.sqrt(d1[ok] * d2[ok])
        rho = rho * math.sqrt(dim) if scaled else rho / math.sqrt(dim)
        out[:-1][ok] = (np.abs(rho) <= 1.96 / np.sqrt(c[ok])).astype(float)
        return out

    def rms(self) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.sqrt(self.sq / self.cnt)


# ---------------------------------------------------------------- segments
def segments(truth: Any, key: str, warmup: float) -> list[tuple[str, float, float]]:
    """(name, start, end) in s from the start: cut at each rudder order and each start of
    a change of the thrust order. Williamson: S1..S6; otherwise Z1.. (zigzag)."""
    t = truth.t - truth.t[0]
    ro = truth.columns["rudder_order"]
    ts = truth.columns["thrust_speed"]
    cuts = set()
    for i in range(1, len(t)):
        if ro[i] != ro[i - 1]:
            cuts.add(float(t[i]))
        if ts[i] != ts[i - 1] and (i < 2 or ts[i - 1] == ts[i - 2]):
            cuts.add(float(t[i]))
    edges = [0.0] + sorted(cuts) + [float(t[-1]) + 0.1]
    prefix = "S" if "williamson" in key else "Z"
    if prefix == "S" and len(edges) != 7:
        print(f"warning: {len(edges) - 1} segments found in {key}, expected S1..S6", file=sys.stderr)
    return [(f"{prefix}{i + 1}", a, b) for i, (a, b) in enumerate(zip(edges[:-1], edges[1:]))]


def steps_in(a: float, b: float, K: int, warmup: float) -> np.ndarray:
    ts = np.arange(K) / 10.0
    return (ts >= max(a, warmup)) & (ts < b)


def pct(x: np.ndarray) -> str:
    x = x[np.isfinite(x)]
    return f"{100.0 * np.mean(x):5.1f}" if len(x) else "    -"


def fmt(v: float, f: str = "{:.4f}") -> str:
    return f.format(v) if math.isfinite(v) else "-"


# ---------------------------------------------------------------- tables
def print_tables(key: str, combo: str, acc: Acc, segs: list, warmup: float, paper: bool) -> None:
    N = acc.n
    K = acc.K
    print(f"\n=== {key} · {combo} · {N} runs · steps of 0.1 s after the first {warmup:g} s ===")
    state = acc.nis_state()
    ac_p = acc.ac_inside("position", False)
    ac_ps = acc.ac_inside("position", True)
    ac_h = acc.ac_inside("heading", False)
    names = [s[0] for s in segs] + ["all"]
    masks = [steps_in(a, b, K, warmup) for _, a, b in segs] + [steps_in(0.0, 1e12, K, warmup)]
    w = 7
    print("(a) average NIS in its χ² 95 % band, % of steps (below / above); ΣNIS/Σdof per kind over the segment")
    print("(b) average autocorrelation k,k+1 in ±1.96/√N, % of steps (eq. 26)")
    print(f"{'':22s}" + "".join(f"{n:>{w}s}" for n in names))
    inside = lambda m: pct(np.where(np.isfinite(state[m]), state[m] == 0, np.nan))  # noqa: E731
    below = lambda m: pct(np.where(np.isfinite(state[m]), state[m] < 0, np.nan))  # noqa: E731
    above = lambda m: pct(np.where(np.isfinite(state[m]), state[m] > 0, np.nan))  # noqa: E731
    print(f"{'NIS in band':22s}" + "".join(f"{inside(m):>{w}s}" for m in masks))
    print(f"{'NIS below':22s}" + "".join(f"{below(m):>{w}s}" for m in masks))
    print(f"{'NIS above':22s}" + "".join(f"{above(m):>{w}s}" for m in masks))
    ref = PAPER.get(combo) if paper else None
    if ref:
        print(f"{'  paper Table 4':22s}" + "".join(f"{v:>{w}d}" for v in ref[0]))
    for i, kind in enumerate(NIS_KINDS):
        vals = []
        for m in masks:
            n_, d_ = acc.kind_nis[m, i, 0].sum(), acc.kind_nis[m, i, 1].sum()
            vals.append(f"{n_ / d_:.2f}" if d_ > 0 else "-")
        print(f"{'  NIS/dof ' + kind:22s}" + "".join(f"{v:>{w}s}" for v in vals))
    print(f"{'AC position':22s}" + "".join(f"{pct(ac_p[m]):>{w}s}" for m in masks))
    print(f"{'AC position·√d':22s}" + "".join(f"{pct(ac_ps[m]):>{w}s}" for m in masks))
    print(f"{'AC heading':22s}" + "".join(f"{pct(ac_h[m]):>{w}s}" for m in masks))
    if ref:
        print(f"{'  paper Table 5':22s}" + "".join(f"{v:>{w}d}" for v in ref[1]))
    elif paper:
        print("  (paper Tables 4/5 for CMM+UKF, CTRA+EKF, CTRA+UKF: 67–80 % NIS, 81–96 % autocorrelation)")
    rms = acc.rms()
    print("(c) RMS error over the runs per step, mean over the segment's steps")
    print(f"{'':8s}" + "".join(f"{s + ' ' + UNITS[s]:>12s}" for s in STATES))
    for n, m in zip(names, masks):
        vals = [np.nanmean(rms[m, i]) if np.any(np.isfinite(rms[m, i])) else float("nan") for i in range(len(STATES))]
        print(f"{n:8s}" + "".join(f"{fmt(v):>12s}" for v in vals))
    raw = {k: math.sqrt(s / c) for k, (s, c) in acc.raw.items() if c}
    print(f"{'sensor':8s}" + "".join(f"{fmt(raw.get(s, float('nan'))):>12s}" for s in STATES)
          + "   (raw measurements of the chosen sources against truth, RMS)")
    per = acc.cpu / max(acc.updates, 1) * 1e6
    per_fed = acc.cpu / max(acc.fed, 1) * 1e6
    divs = Counter(acc.per_run_div)
    print(f"(d) divergences {acc.div} (runs with n divergences: {dict(sorted(divs.items()))}); "
          f"CPU {acc.cpu:.1f} s, {per:.1f} µs per filter update ({acc.updates / max(N, 1):.0f} a run), "
          f"{per_fed:.1f} µs per measurement fed, ticks and predictions included")
    print(f"    non-finite estimate values {acc.nan_est}, non-finite NIS {acc.bad_nis}; "
          f"events {dict(sorted(acc.events.items()))}; rejected {dict(sorted(acc.rejected.items()))}")


def print_predict(key: str, combo: str, acc: Acc, horizons: list[float]) -> None:
    if not acc.preds:
        print(f"\n(prediction) {key} · {combo}: no fresh predictions")
        return
    p = np.concatenate(acc.preds)
    print(f"\n=== prediction · {key} · {combo} · {acc.n} runs: horizontal error of the predicted "
          f"position against truth at t+dt, beside dead reckoning (latest fix + latest SOG/COG) ===")
    print(f"{'dt s':>6s} {'':9s} {'n':>6s} {'RMS model':>10s} {'RMS DR':>9s} {'model/DR':>9s} "
          f"{'med model':>10s} {'med DR':>8s} {'in 1σ %':>8s} {'in 2σ %':>8s} {'d²/2':>6s}")
    for hi, hz in enumerate(horizons):
        for name, turning in (("turning", 1.0), ("straight", 0.0)):
            s = p[(p[:, 0] == hi) & (p[:, 1] == turning)]
            if not len(s):
                continue
            rm = math.sqrt(np.mean(s[:, 2] ** 2))
            rd = math.sqrt(np.mean(s[:, 3] ** 2))
            print(f"{hz:6g} {name:9s} {len(s):6d} {rm:10.2f} {rd:9.2f} {rm / rd:9.2f} {np.median(s[:, 2]):10.2f} "
                  f"{np.median(s[:, 3]):8.2f} {100 * np.mean(s[:, 4] <= 1.0):8.1f} {100 * np.mean(s[:, 4] <= 4.0):8.1f}"
                  f" {np.mean(s[:, 4]) / 2:6.2f}")
    print(f"{'dt s':>6s} {'share of truths inside the 1σ / 2σ ellipse, all predictions and by when they were made':s}")
    for hi, hz in enumerate(horizons):
        s = p[p[:, 0] == hi]
        cells = []
        for lo_t, hi_t in ((0.0, math.inf), (0.0, 300.0), (300.0, math.inf)):
            w = s[(s[:, 5] >= lo_t) & (s[:, 5] < hi_t)]
            if len(w):
                cells.append(f"{lo_t:g}–{hi_t:g} s {100 * np.mean(w[:, 4] <= 1.0):5.1f} / {100 * np.mean(w[:, 4] <= 4.0):5.1f}")
        print(f"{hz:6g} " + "   ".join(cells))
    print("    nominal: 39.3 % inside 1σ, 86.5 % inside 2σ; turning: |true r(t)| > 0.1°/s; d²/2: mean squared "
          "Mahalanobis distance of the truth over its 2 degrees of freedom (1 when the covariance is right)")


def print_north(key: str, combo: str, acc: Acc, rot: Acc, truth: Any, half: float = 10.0) -> None:
    t = truth.t - truth.t[0]
    psi = truth.columns["heading"]
    cross = [float(t[i]) for i in range(1, len(t)) if abs(psi[i] - psi[i - 1]) > math.pi]
    print(f"\n=== north crossings · {key} · {combo} · {acc.n} runs: ±{half:g} s around each crossing of "
          f"0/360° by the true heading, against the same window of the run turned by 180° ===")
    print(f"{len(cross)} crossings")
    s_a, s_b = acc.nis_state(), rot.nis_state()
    with np.errstate(invalid="ignore", divide="ignore"):
        r_a = acc.nis / acc.dof
        r_b = rot.nis / rot.dof
    rms_a, rms_b = acc.rms(), rot.rms()
    cols = ("u", "v", "r", "heading", "pos")
    ci = [STATES.index(c) for c in cols]
    print(f"{'t s':>7s} | {'max NIS/dof':>11s} {'out %':>6s} | " + " ".join(f"{c:>8s}" for c in cols)
          + f" | {'rot max':>8s} {'out %':>6s} | " + " ".join(f"{c:>8s}" for c in cols))
    tot = []
    for tc in cross:
        m = (np.arange(acc.K) / 10.0 >= tc - half) & (np.arange(acc.K) / 10.0 <= tc + half)
        oa = np.nanmean(np.abs(s_a[m])) * 100
        ob = np.nanmean(np.abs(s_b[m])) * 100
        ea = [np.nanmean(rms_a[m, i]) for i in ci]
        eb = [np.nanmean(rms_b[m, i]) for i in ci]
        tot.append((np.nanmax(r_a[m]), oa, *ea, np.nanmax(r_b[m]), ob, *eb))
        print(f"{tc:7.1f} | {np.nanmax(r_a[m]):11.3f} {oa:6.1f} | " + " ".join(f"{v:8.4f}" for v in ea)
              + f" | {np.nanmax(r_b[m]):8.3f} {ob:6.1f} | " + " ".join(f"{v:8.4f}" for v in eb))
    if tot:
        a = np.array(tot)
        n = len(cols)
        print(f"{'mean':>7s} | {np.mean(a[:, 0]):11.3f} {np.mean(a[:, 1]):6.1f} | "
              + " ".join(f"{v:8.4f}" for v in a[:, 2:2 + n].mean(axis=0))
              + f" | {np.mean(a[:, 2 + n]):8.3f} {np.mean(a[:, 3 + n]):6.1f} | "
              + " ".join(f"{v:8.4f}" for v in a[:, 4 + n:].mean(axis=0)))
    print("    NIS/dof: ΣNIS/Σdof over the runs per step (1 expected); out %: steps whose average NIS "
          "is outside its band; errors in m/s, °/s, °, m")


# ---------------------------------------------------------------- main
def sources_report(ms: list) -> None:
    c = Counter((m.kind, m.source) for m in ms)
    span = (ms[-1].t - ms[0].t) if ms else 1.0
    print("sources in the logs (run 0): kind, source, rate; * fed to the core, + dead reckoning")
    for (kind, src), n in sorted(c.items()):
        if kind not in SOURCES and kind != "velocity_ground":
            continue
        mark = "*" if SOURCES.get(kind) == src else ("+" if kind == "velocity_ground" and src == DR_SOURCE else " ")
        print(f"  {mark} {kind:16s} {src:16s} {n / span:6.1f} Hz")
    missing = [f"{k}={s}" for k, s in SOURCES.items() if (k, s) not in c]
    if missing:
        raise SystemExit(f"sources not in the logs: {', '.join(missing)}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenario", default="manoeuvre-williamson")
    p.add_argument("--runs", type=int, default=50)
    p.add_argument("--combos", default=",".join(COMBOS))
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--out", default=str(Path(tempfile.gettempdir()) / "edged-mc-manoeuvre"),
                   help="cache of simulated runs, reused (default: %(default)s)")
    p.add_argument("--mode", choices=["tuned", "paper"], default="tuned")
    p.add_argument("--warmup", type=float, default=30.0)
    p.add_argument("--north", action="store_true", help="also the zigzag turned by 180°; NIS and RMSE around north")
    p.add_argument("--predict", action="store_true", help="prediction error against truth and dead reckoning")
    p.add_argument("--quick", action="store_true", help="3 runs, ctra+ekf only")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="a configuration value of the estimator (a number), e.g. --set q_yaw_accel=1e-6")
    a = p.parse_args(argv)
    if a.quick:
        a.runs, a.combos = 3, "ctra+ekf"
    combos = [c.strip() for c in a.combos.split(",") if c.strip()]
    for c in combos:
        m, _, f = c.partition("+")
        if m not in ("ctra", "cmm") or f not in ("ekf", "ukf", "enkf"):
            raise SystemExit(f"bad combination {c!r}: model+filter, model ctra|cmm, filter ekf|ukf|enkf")
    print("command: " + " ".join([Path(sys.executable).name, *sys.argv]))
    print(f"scenario {a.scenario}, {a.runs} runs (sim seeds 0..{a.runs - 1}, initial error from P0 with "
          f"default_rng(1000 + j)), combos {', '.join(combos)}, mode {a.mode}, warm-up {a.warmup:g} s, "
          f"jobs {a.jobs}, cache {a.out}")
    keys = [a.scenario] + ([a.scenario + ROT] if a.north else [])
    wall0 = time.perf_counter()
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(a.jobs) as pool:
        dirs = pool.map(prepare, [(k, j, a.out) for k in keys for j in range(a.runs)], chunksize=1)
        print(f"runs simulated/decoded (or cached) in {time.perf_counter() - wall0:.0f} s")
        d0 = {k: dirs[i * a.runs] for i, k in enumerate(keys)}
        sources_report(load_ms(d0[keys[0]]))
        truth = {k: load_truth_dir(d0[k]) for k in keys}
        K = {k: len(truth[k].t) + 1 for k in keys}
        tasks = [{"dir": dirs[i * a.runs + j], "seed": j, "key": k, "combo": c, "mode": a.mode,
                  "warmup": a.warmup, "predict": a.predict,
                  "set": {kv.split("=", 1)[0]: float(kv.split("=", 1)[1]) for kv in a.set}}
                 for c in combos for i, k in enumerate(keys) for j in range(a.runs)]
        accs = {(k, c): Acc(K[k]) for k in keys for c in combos}
        segs = {k: segments(truth[k], k, a.warmup) for k in keys}
        for k in keys:
            print(f"segments of {k}: " + ", ".join(f"{n} {s:.1f}–{e:.1f} s" for n, s, e in segs[k]))
        for r in pool.imap(run_one, tasks, chunksize=1):
            acc = accs[(r["key"], r["combo"])]
            acc.add(r)
            print(f"  {r['key']} {r['combo']} run {r['seed']}: {r['cpu']:.1f} s CPU, "
                  f"{r['divergences']} divergences", file=sys.stderr, flush=True)
            if acc.n == a.runs:  # a combination's tables as soon as its runs are in
                print_tables(r["key"], r["combo"], acc, segs[r["key"]], a.warmup, "williamson" in r["key"])
                sys.stdout.flush()
    wall = time.perf_counter() - wall0
    horizons = [float(h) for h in ManoeuvreConfig(type="manoeuvre").horizons]
    if a.north:
        for c in combos:
            print_north(a.scenario, c, accs[(a.scenario, c)], accs[(a.scenario + ROT, c)], truth[a.scenario])
    if a.predict:
        for k in keys:
            for c in combos:
                print_predict(k, c, accs[(k, c)], horizons)
    print(f"\nwall time {wall:.0f} s with {a.jobs} jobs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
