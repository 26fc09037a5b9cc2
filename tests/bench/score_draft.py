"""Draft estimator quality over several seeds, and what one failing mark does to it.

    python tests/bench/score_draft.py [--seeds 5] [--jobs 2] [--out DIR] [--scenarios NAME ...]
                                      [--set KEY=VALUE ...] [--json]

Scenarios (`--scenarios`, default all):
- `draft-harbour`, `draft-squat`: the simulator's scenarios as they are;
- `harbour-jonswap`, `squat-jonswap`: the same with `--waves jonswap:1.13,12` and
  `jonswap:1.13,10` (Hs 1.13 m = 2√2 × 0.4 m: the regular seas' energy, irregular);
- `draft-travelling`, `draft-short-crested` (issue 31): the marks read the sea at their
  own places, a regular sea of the hull's length 30° off the stern, and a short-crested
  JONSWAP sea (Hs 1 m, Tp 10 s, 30° spread) from abeam;
- `draft-faulty-mark`: the fore_port mark fails five ways, 120 s each (meta.json
  `faults.windows`), beside a clean `draft-harbour` of the same seed and 1200 s.

For each seed and scenario: `edged sim` (skipped when the out dir already holds the
run's four files), then `edged replay -c CFG nmea.log can.log --no-zenoh --no-progress
--record run.mcap` with `[estimators.stw]`, `[estimators.draft]` (adaptive) and
`[estimators.draft_paper]` (mode = "paper"), then `edged score run.mcap --truth
truth.csv --warmup 60 --json`. Both draft instances get the vessel's figures from
meta.json as a user would take them from her documents: mark_spacing = the distance
between the fore and aft marks (the simulator's marks are at the perpendiculars, so
L), beam, block_coefficient, the channel's blockage b·T/(W·h) at the starting draft
(none in open water), transducer_x = the echo sounder's position ahead of midships
in m, transducer_height = 0 (the simulated sounder sits at the keel). The paper
instance's omega_e is what a user would set from the sea state: 2π/T (T the regular
period or the peak period), corrected for the ship's speed to the encounter
frequency |ω − k·U·cos μ| (deep water, k = ω²/g, as the simulator has it) with U the
mean ordered speed over the scored time and μ the waves' direction relative to the
bow (meta.json's heading and waves). `--set KEY=VALUE` (repeatable) overrides a key
of the adaptive instance (the value as TOML, else a string).

Prints per scenario a table over seeds (RMS over seeds, and min–max), in cm: per mark
the filtered instantaneous draft and the mean draft, adaptive and paper, beside the
raw sensor (its readings against the same truth); mean_draft, trim, list,
deflection, squat, ukc where scored. For the harbour scenarios: the lag of the mean
draft during discharge (the shift of the estimate in time that best aligns it with
the truth from a minute into the discharge to its end; on a steady ramp a lag and a
bias are the same thing, so the mean error is printed beside it). For
draft-faulty-mark, per seed and fault window: the largest |faulty − clean| of
mean_draft, trim and list in the window (and in the 90 s after it), the share of the
window the fore_port mark is reported not ok and how soon, how long after the window
it is ok again, and the publishing rate in the window (est/draft messages per second,
the least over 10-s bins). Then the command line and the wall time. About 10 CPU
minutes per seed with all scenarios (the replays dominate).
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

EDGED = [sys.executable, "-m", "edged.cli"]
G = 9.80665
KNOT = 1852.0 / 3600.0
WARMUP = 60.0
MARKS = ("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd")
FIELDS = ("mean_draft", "trim", "list", "deflection", "squat", "ukc")
INSTANCES = ("draft", "draft_paper")
SIM_FILES = ("nmea.log", "can.log", "truth.csv", "meta.json")

#: label -> (scenario, --waves or None, --duration or None)
RUNS: dict[str, tuple[str, str | None, float | None]] = {
    "draft-harbour": ("draft-harbour", None, None),
    "draft-squat": ("draft-squat", None, None),
    "harbour-jonswap": ("draft-harbour", "jonswap:1.13,12", None),
    "squat-jonswap": ("draft-squat", "jonswap:1.13,10", None),
    "draft-faulty-mark": ("draft-faulty-mark", None, None),
    "harbour-1200": ("draft-harbour", None, 1200.0),  # the faulty run's clean twin
    "draft-travelling": ("draft-travelling", None, None),
    "draft-short-crested": ("draft-short-crested", None, None),
}
SCENARIOS = ("draft-harbour", "draft-squat", "harbour-jonswap", "squat-jonswap", "draft-faulty-mark",
             "draft-travelling", "draft-short-crested")
#: Each fault window of draft-faulty-mark is followed by this much of recovery (s).
AFTER = 90.0


# --------------------------------------------------------------------------- config
def _marks_spacing(length: float) -> float:
    """Distance between the fore and aft marks: the simulator's marks (truth.MARKS)."""
    from edged_sim.truth import MARKS as SIM_MARKS

    xs = [fx for _, fx, _ in SIM_MARKS]
    return (max(xs) - min(xs)) * length


def ordered_speed(helm: dict, t0: float, t1: float) -> float:
    """Mean ordered speed through water (m/s) over [t0, t1] from meta.json's helm:
    the initial speed and the time-fired speed orders with their ramps."""
    ts = np.linspace(t0, t1, 2001)
    v = np.full_like(ts, float(helm.get("speed_kn", 0.0)))
    for st in helm.get("steps", []):
        if st.get("at_s") is None or st.get("speed_kn") is None:
            continue  # heading-fired orders: not in the draft scenarios
        a, r = float(st["at_s"]), float(st.get("ramp_s", 0.0))
        before = np.interp(a, ts, v)
        frac = np.clip((ts - a) / r, 0.0, 1.0) if r > 0 else (ts >= a).astype(float)
        v = np.where(ts >= a, before + (float(st["speed_kn"]) - before) * frac, v)
    return float(np.mean(v)) * KNOT


def wave_period(waves: dict) -> float | None:
    if waves.get("type") == "RegularWaves":
        return float(waves["period"])
    if waves.get("type") == "JonswapWaves":
        return float(waves["tp"])
    return None


def particulars(meta: dict) -> tuple[dict, dict]:
    """The vessel's figures for [estimators.draft], and the paper instance's omega_e
    with how it was found."""
    ship, water, loading = meta["ship"], meta["water"], meta["loading"]
    length = float(ship["length"])
    p: dict[str, object] = {
        "mark_spacing": round(_marks_spacing(length), 3),
        "beam": ship["beam"],
        "block_coefficient": ship["block_coefficient"],
        "transducer_x": round(float(loading["transducer_x"]) * length, 3),
        "transducer_height": 0.0,
    }
    if water.get("channel_width"):
        draft0 = float(loading["draft_knots"][0][1])
        p["blockage"] = round(float(ship["beam"]) * draft0 / (float(water["channel_width"]) * float(water["depth"])), 4)
    period = wave_period(meta["waves"])
    info: dict[str, object] = {"period": period}
    if period is not None:
        w = 2.0 * math.pi / period
        u = ordered_speed(meta["helm"], WARMUP, float(meta["duration_s"]))
        toward = math.radians(float(meta["waves"]["from_deg"]) + 180.0)
        mu = toward - math.radians(float(meta.get("heading_deg", 0.0)))
        we = abs(w - w * w / G * u * math.cos(mu))
        info.update(omega=w, speed=u, mu_deg=math.degrees(mu) % 360.0, omega_e=max(we, 0.01))
    return p, info


def _toml_value(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(float(v)) if isinstance(v, float) else str(v)
    return json.dumps(str(v))


def parse_set(items: list[str]) -> dict[str, str]:
    """`KEY=VALUE` -> {KEY: TOML text}: VALUE as TOML when it parses, else a string."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise SystemExit(f"score_draft: --set wants KEY=VALUE, got {item!r}")
        try:
            tomllib.loads(f"x = {value}")
            out[key] = value.strip()
        except tomllib.TOMLDecodeError:
            out[key] = json.dumps(value)
    return out


def config_text(meta: dict, overrides: dict[str, str]) -> tuple[str, dict]:
    p, info = particulars(meta)
    body = "".join(f"{k} = {_toml_value(v)}\n" for k, v in p.items())
    adaptive = dict((k, _toml_value(v)) for k, v in p.items())
    adaptive.update(overrides)
    text = '[estimators.stw]\ntype = "stw"\n\n[estimators.draft]\ntype = "draft"\n'
    text += "".join(f"{k} = {v}\n" for k, v in adaptive.items())
    text += '\n[estimators.draft_paper]\ntype = "draft"\nmode = "paper"\n' + body
    if "omega_e" in info:
        text += f"omega_e = {info['omega_e']!r}\n"
    return text, {**info, "particulars": p}


# --------------------------------------------------------------------------- one run
def _run(cmd: list[str], what: str, **kw) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        raise RuntimeError(f"{what} failed ({r.returncode}): {shlex.join(cmd)}\n{r.stderr.strip()[-2000:]}")
    return r


def simulate(out: Path, label: str, seed: int) -> Path:
    scenario, waves, duration = RUNS[label]
    d = out / f"{label}-{seed}"
    if all((d / f).exists() for f in SIM_FILES):
        return d
    d.mkdir(parents=True, exist_ok=True)
    cmd = EDGED + ["sim", scenario, "--out", str(d), "--seed", str(seed)]
    cmd += ["--waves", waves] if waves else []
    cmd += ["--duration", str(duration)] if duration else []
    _run(cmd, "sim")
    return d


def read_estimates(rec: Path) -> dict[str, list[dict]]:
    from mcap.reader import make_reader

    out: dict[str, list[dict]] = {n: [] for n in INSTANCES}
    with rec.open("rb") as f:
        for _, ch, msg in make_reader(f).iter_messages(topics=[f"/est/{n}" for n in INSTANCES]):
            out[ch.topic.removeprefix("/est/")].append(json.loads(msg.data))
    for v in out.values():
        v.sort(key=lambda e: e["t"])
    return out


def read_truth(path: Path, cols: tuple[str, ...]) -> dict[str, np.ndarray]:
    header = path.open().readline().strip().split(",")
    idx = [header.index(c) for c in cols]
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=idx, ndmin=2)
    return {c: data[:, i] for i, c in enumerate(cols)}


def discharge_lag(est: list[dict], truth: dict[str, np.ndarray], meta: dict) -> dict | None:
    """Lag (s) of est mean_draft behind the truth during discharge, and the mean error."""
    knots = meta["loading"]["draft_knots"]
    seg = next(((a, b) for (a, da), (b, db) in zip(knots, knots[1:]) if da != db), None)
    if seg is None:
        return None
    t0 = meta["start_time"]
    a, b = seg[0] + 60.0, min(seg[1], float(meta["duration_s"]))
    pts = [(e["t"] - t0, e["mean_draft"]) for e in est if e.get("mean_draft") is not None and a <= e["t"] - t0 <= b]
    if len(pts) < 30:
        return None
    t, y = np.array(pts).T
    tt, ty = truth["t_rel"], truth["mean_draft"]
    shifts = np.round(np.arange(-120.0, 120.001, 0.1), 1)
    rms = [math.sqrt(float(np.mean((y - np.interp(t - s, tt, ty)) ** 2))) for s in shifts]
    i = int(np.argmin(rms))
    err = y - np.interp(t, tt, ty)
    rate = (knots[-1][1] - knots[0][1]) / (seg[1] - seg[0]) if seg[1] > seg[0] else 0.0
    return {"lag_s": float(shifts[i]) + 0.0, "rms_at_lag_cm": 100 * rms[i], "mean_err_cm": 100 * float(np.mean(err)),
            "window_s": [a, b], "rate_mm_s": 1000 * rate}


def run_one(out: Path, label: str, seed: int, overrides: dict[str, str]) -> dict:
    d = simulate(out, label, seed)
    meta = json.loads((d / "meta.json").read_text())
    text, info = config_text(meta, overrides)
    cfg = d / "draft.toml"
    cfg.write_text(text)
    rec = d / "run.mcap"
    t = time.perf_counter()
    _run(EDGED + ["replay", "-c", str(cfg), str(d / "nmea.log"), str(d / "can.log"), "--no-zenoh", "--no-progress",
                  "--record", str(rec)], "replay")
    replay_s = time.perf_counter() - t
    rows = json.loads(_run(EDGED + ["score", str(rec), "--truth", str(d / "truth.csv"), "--warmup", str(WARMUP),
                                    "--json"], "score").stdout)
    scores: dict[str, dict] = {}
    for r in rows:
        if r["estimate"] not in INSTANCES:
            continue
        key = r["estimate"] if not r["baseline"] else "raw"
        if key == "raw" and r["estimate"] != "draft":
            continue  # the same readings beside either instance
        scores.setdefault(key, {})[r["field"]] = {k: r[k] for k in ("rmse", "bias", "n", "max_abs")}
    res = {"label": label, "seed": seed, "dir": str(d), "scores": scores, "config": info, "replay_s": replay_s}
    if label in ("draft-harbour", "harbour-jonswap", "draft-faulty-mark", "harbour-1200"):
        est = read_estimates(rec)
        if label in ("draft-harbour", "harbour-jonswap"):
            truth = read_truth(d / "truth.csv", ("t_rel", "mean_draft"))
            res["lag"] = {n: discharge_lag(est[n], truth, meta) for n in INSTANCES}
        else:
            res["est"] = est  # compared with its twin afterwards
            res["meta"] = meta
    return res


# --------------------------------------------------------------------------- faults
def _label(w: dict) -> str:
    if w["kind"] == "outage":
        return "silence"
    if w["kind"] == "offset":
        return f"{w['field']} {w['value']:+g}"
    if w["kind"] == "forced":
        return f"{w['field']} = {w['value']:g}"
    if w["kind"] == "dropout":
        return f"{100 * w['probability']:g} % lost"
    return w["kind"]


def fault_table(faulty: dict, clean: dict, instance: str = "draft") -> list[dict]:
    meta = faulty["meta"]
    t0 = meta["start_time"]
    F, C = faulty["est"][instance], clean["est"][instance]
    cidx = {round(e["t"], 3): e for e in C}
    windows = sorted(meta["faults"]["windows"], key=lambda w: w["start_s"])
    out = []
    for i, w in enumerate(windows):
        a, b = float(w["start_s"]), float(w["end_s"])
        nxt = windows[i + 1]["start_s"] if i + 1 < len(windows) else float(meta["duration_s"])
        after_end = min(b + AFTER, nxt)
        inside = [e for e in F if a <= e["t"] - t0 < b]
        after = [e for e in F if b <= e["t"] - t0 < after_end]

        def maxd(es: list[dict], f: str) -> tuple[float | None, int]:
            ds, nulls = [], 0
            for e in es:
                c = cidx.get(round(e["t"], 3))
                if c is None or e.get(f) is None or c.get(f) is None:
                    nulls += 1
                    continue
                ds.append(abs(e[f] - c[f]))
            return (100 * max(ds) if ds else None), nulls

        row: dict[str, object] = {"seed": faulty["seed"], "fault": _label(w), "window": [a, b]}
        for f in ("mean_draft", "trim", "list"):
            row[f], row[f"{f}_missing"] = maxd(inside, f)
        row["mean_draft_after"], _ = maxd(after, "mean_draft")
        bad = [e["t"] - t0 for e in inside if not e["marks"]["fore_port"]["ok"]]
        row["not_ok_share"] = len(bad) / len(inside) if inside else None
        row["not_ok_after_s"] = (bad[0] - a) if bad else None
        ok_again = None  # first instant after the window from which fore_port stays ok
        for e in after:
            if e["marks"]["fore_port"]["ok"]:
                if ok_again is None:
                    ok_again = e["t"] - t0 - b
            else:
                ok_again = None
        row["ok_again_s"] = ok_again if after and after[-1]["marks"]["fore_port"]["ok"] else None
        bins = np.zeros(int(math.ceil((b - a) / 10.0)))
        for e in inside:
            bins[min(int((e["t"] - t0 - a) // 10.0), bins.size - 1)] += 1
        row["min_rate_hz"] = float(bins.min() / 10.0) if bins.size else None
        out.append(row)
    return out


# --------------------------------------------------------------------------- printing
def _rms(xs: list[float]) -> float:
    return math.sqrt(statistics.mean(x * x for x in xs))


def _cell(xs: list[float | None], scale: float = 100.0, digits: int = 1) -> str:
    xs = [x * scale for x in xs if x is not None]
    if not xs:
        return "–"
    if len(xs) == 1:
        return f"{xs[0]:.{digits}f}"
    return f"{_rms(xs):.{digits}f} ({min(xs):.{digits}f}–{max(xs):.{digits}f})"


def scenario_table(label: str, res: list[dict]) -> list[str]:
    seeds = [r["seed"] for r in res]
    cfg = res[0]["config"]
    lines = [f"\n### {label} (seeds {seeds[0]}–{seeds[-1]}, scored after {WARMUP:g} s), RMSE in cm: RMS over seeds "
             f"(min–max)"]
    if cfg.get("omega_e") is not None:
        lines.append(f"paper omega_e = {cfg['omega_e']:.4f} rad/s (2π/{cfg['period']:g} s = {cfg['omega']:.4f} at "
                     f"{cfg['speed'] / KNOT:.1f} kn, waves toward {cfg['mu_deg']:.0f}° off the bow)")

    def col(inst: str, f: str) -> list[float | None]:
        return [r["scores"].get(inst, {}).get(f, {}).get("rmse") for r in res]

    lines += ["| mark | draft adaptive | draft paper | draft raw | mean adaptive | mean paper | mean raw |",
              "|---|---|---|---|---|---|---|"]
    for m in MARKS:
        d, mn = f"marks.{m}.draft", f"marks.{m}.mean"
        lines.append(f"| {m} | {_cell(col('draft', d))} | {_cell(col('draft_paper', d))} | {_cell(col('raw', d))} | "
                     f"{_cell(col('draft', mn))} | {_cell(col('draft_paper', mn))} | {_cell(col('raw', mn))} |")
    lines += ["", "| field | adaptive | paper |", "|---|---|---|"]
    for f in FIELDS:
        a, p = col("draft", f), col("draft_paper", f)
        if all(x is None for x in a + p):
            continue
        lines.append(f"| {f} | {_cell(a)} | {_cell(p)} |")
    if any(r.get("lag") for r in res):
        lines += ["", "| mean draft in discharge | lag s adaptive | lag s paper | mean error cm adaptive | "
                  "mean error cm paper |", "|---|---|---|---|---|"]
        for r in res:
            la, lp = r["lag"]["draft"], r["lag"]["draft_paper"]

            def g(x: dict | None, k: str, fmt: str) -> str:
                return format(x[k], fmt) if x else "–"

            lines.append(f"| seed {r['seed']} | {g(la, 'lag_s', '+.1f')} | {g(lp, 'lag_s', '+.1f')} | "
                         f"{g(la, 'mean_err_cm', '+.2f')} | {g(lp, 'mean_err_cm', '+.2f')} |")
        w = next((r["lag"]["draft"] for r in res if r["lag"]["draft"]), None)
        if w:
            lines.append(f"(discharge {w['window_s'][0]:.0f}–{w['window_s'][1]:.0f} s at {w['rate_mm_s']:+.2f} mm/s: "
                         f"a lag of 10 s is {abs(w['rate_mm_s']):.1f} cm)")
    return lines


def fault_lines(rows: list[dict], instance: str) -> list[str]:
    lines = [f"\n### draft-faulty-mark vs clean draft-harbour, est/{instance}: fore_port failing "
             f"(|faulty − clean| max in cm, in the window; mean draft also in the {AFTER:g} s after)",
             "| seed | fault | window s | Δ mean_draft | Δ trim | Δ list | Δ mean after | fore_port not ok | "
             "ok again after | min rate /s |",
             "|---|---|---|---|---|---|---|---|---|---|"]

    def f1(x: float | None, fmt: str = ".1f") -> str:
        return "–" if x is None else format(x, fmt)

    for r in rows:
        share = r["not_ok_share"]
        nok = "–" if share is None else (f"{100 * share:.0f} %" + (f" from +{r['not_ok_after_s']:.0f} s"
                                                                    if r["not_ok_after_s"] is not None else ""))
        miss = r["mean_draft_missing"]
        lines.append(f"| {r['seed']} | {r['fault']} | {r['window'][0]:.0f}–{r['window'][1]:.0f} | "
                     f"{f1(r['mean_draft'])}{f' ({miss} null)' if miss else ''} | {f1(r['trim'])} | {f1(r['list'])} | "
                     f"{f1(r['mean_draft_after'])} | {nok} | "
                     f"{'no' if r['ok_again_s'] is None else format(r['ok_again_s'], '.0f') + ' s'} | "
                     f"{f1(r['min_rate_hz'], '.1f')} |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--scenarios", nargs="+", choices=SCENARIOS, default=list(SCENARIOS), metavar="NAME",
                    help=f"some of {', '.join(SCENARIOS)}")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a draft configuration key of the adaptive instance (repeatable)")
    ap.add_argument("--json", action="store_true", help="the figures as JSON instead of tables")
    a = ap.parse_args()
    start = time.perf_counter()
    overrides = parse_set(a.set)
    out = a.out or Path(tempfile.mkdtemp(prefix="score_draft-"))
    labels = [s for s in SCENARIOS if s in a.scenarios]
    if "draft-faulty-mark" in labels:
        labels.append("harbour-1200")
    jobs = [(lb, s) for s in range(1, a.seeds + 1) for lb in labels]
    # The longest replays first, so that the pool's tail is short.
    order = {"draft-harbour": 0, "harbour-jonswap": 1, "draft-faulty-mark": 2, "harbour-1200": 3}
    jobs.sort(key=lambda j: (order.get(j[0], 9), j[1]))
    try:
        with ThreadPoolExecutor(a.jobs) as ex:
            results = list(ex.map(lambda j: run_one(out, j[0], j[1], overrides), jobs))
    except RuntimeError as exc:
        raise SystemExit(f"score_draft: {exc}") from None
    by: dict[str, list[dict]] = {}
    for r in results:
        by.setdefault(r["label"], []).append(r)
    for v in by.values():
        v.sort(key=lambda r: r["seed"])
    faults: dict[str, list[dict]] = {}
    if "draft-faulty-mark" in by:
        clean = {r["seed"]: r for r in by.pop("harbour-1200")}
        for inst in INSTANCES:
            faults[inst] = [row for r in by["draft-faulty-mark"] for row in fault_table(r, clean[r["seed"]], inst)]
    wall = time.perf_counter() - start
    command = shlex.join([Path(sys.executable).name, *sys.argv])
    if a.json:
        for v in by.values():
            for r in v:
                r.pop("est", None), r.pop("meta", None)
        print(json.dumps({"command": command, "wall_s": wall, "overrides": overrides, "out": str(out),
                          "runs": by, "faulty_mark": faults}, indent=1, default=float))
        return
    lines: list[str] = []
    if overrides:
        lines.append(f"adaptive instance with {', '.join(f'{k} = {v}' for k, v in overrides.items())}")
    for lb in labels:
        if lb in by and lb != "draft-faulty-mark":
            lines += scenario_table(lb, by[lb])
    if faults:
        lines += scenario_table("draft-faulty-mark", by["draft-faulty-mark"])
        for inst in INSTANCES:
            lines += fault_lines(faults[inst], inst)
    replay = sum(r["replay_s"] for r in results)
    lines += [f"\nfiles in {out}", f"command: {command}",
              f"wall time {wall:.0f} s ({a.jobs} jobs; replays {replay:.0f} s in all)"]
    print("\n".join(lines))


if __name__ == "__main__":
    main()
