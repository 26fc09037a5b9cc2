"""The manoeuvring-state estimator on the real logs of ../shared/data: which logs, how
they are fed, and the figures both the tests (tests/manoeuvre/test_real_logs.py) and the
bench (tests/bench/manoeuvre_real.py) read from one run.

Feeding is what the worker host does with a replay: every measurement of the kinds the
core takes (one source per kind, the first seen, `manoeuvre_data.select`) in time
order, `tick` on a 0.1 s grid of data time before each record. Two things a replay of
these logs needs that a simulator's never does:
- time that jumps (the can0-1 capture's 0.43 s stamped 13.9 days early): the tick grid
  restarts at the next record instead of publishing every 0.1 s of a gap nobody
  recorded (the worker host's clock does not tick through a log's holes either);
- the same fix delivered more than once: an NMEA 0183 talker sends one fix as GGA, RMC
  and GLL with one time, and Aava's GNSS sends each fix as PGN 129025 and again 0.5 s
  later as 129029. `dedupe_fixes` keeps one of them (a fix equal to the last kept one
  of its source, less than 0.9 s after it): one fix is one measurement of the position,
  not three. A static receiver's repeated fix is still kept once a second;
- NMEA 0183 text without per-line times: every sentence has the time of the last
  time-bearing one, so ten headings of a second arrive at one instant;
  `spread_same_time` spreads them over the second as a live input would stamp them.
"""

from __future__ import annotations

import functools
import logging
import math
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from edged.records import Estimate, Measurement
from edged_manoeuvre.config import ManoeuvreConfig
from edged_manoeuvre.core import ManoeuvreCore
from manoeuvre_data import measurements, select

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
KINDS = ("position", "heading", "yaw_rate", "accel_body", "velocity_ground")
#: The publish grid (s of data time) and the gap after which it restarts.
TICK = 0.1
GAP = 5.0


@dataclass(frozen=True)
class Log:
    """A real log with position and heading, and what it is (from INDEX.md and the file)."""

    path: str  # under ../shared/data
    vessel: str
    #: Bounds on the body velocities over ground a vessel of this kind can have (m/s):
    #: surge from its hull speed (a displacement hull: 1.34 √LWL[ft] kn) with 25 %
    #: margin, sway from leeway/swinging (≤ 0.5 m/s) plus the cross component of the
    #: strongest tidal current where it sails (v is over ground, the current is in it).
    u_max: float
    v_max: float
    date: str | None = None
    #: Config fields a user of this log must set. The default start is a line through
    #: >= 3 fixes of the last init_window = 1 s: a 1 Hz GNSS (the NMEA 0183 logs here,
    #: one fix a second once GGA/RMC/GLL count once) or the furuno log's 0.7 Hz one
    #: (fixes 1.0-2.8 s apart) never gives three; a user sets a window that holds three.
    config: dict[str, Any] = field(default_factory=dict)


LOGS = {
    "furuno": Log(
        "n2k/canboat__samples__furuno-fap7011c-autopilot-maneuvers.raw",
        "Furuno FAP7011C autopilot doing manoeuvres, San Francisco approaches (37.57 N "
        "122.78 W) 2021-08-06, 171 s. Heading 127250 at 40 Hz and rate of turn 127251 at "
        "10 Hz from src 36; 129025/129026 from src 36 all 'not available'; the only fixes "
        "are 129029 from src 3 at 0.7 Hz (1.0-2.8 s apart), rounded to 1e-5 deg. The "
        "track runs 213 deg at 5.9 m/s while the heading stays 142.9-143.5 deg.",
        u_max=10.0, v_max=2.0, config={"init_window": 5.0}),
    "dirona": Log(
        "n2k/canboat__samples__dirona-actisense-serial.raw",
        "MV Dirona, Nordhavn 52 trawler (LWL ~14 m: hull speed 9.3 kn), 2016-02-28, 64 s, "
        "lying still (SOG < 0.2 m/s). Heading 127250 and rate of turn 127251 from src 7 at "
        "80 Hz (and src 105 at 20 Hz), position 129025 src 7 at 12 Hz (and src 33).",
        u_max=6.0, v_max=2.0),
    "susteranna": Log(
        "n2k/canboat__samples__susteranna-actisense-serial.raw",
        "SY Suster Anna (sailing yacht), 2016-04-09, 31 s, still. Heading 127250 src 128 "
        "at 10 Hz, rate of turn 127251 src 15 at 20 Hz, position 129025 src 0 at 10 Hz "
        "(three GNSS sources in all).",
        u_max=6.0, v_max=2.0),
    "susteranna2020": Log(
        "n2k/canboat__samples__susteranna2020.raw",
        "SY Suster Anna, 2020-08-22, 26 s (one gap > 1 s), still. Heading src 128 at "
        "5 Hz, rate of turn src 23 at 10 Hz, position src 18 at 5 Hz; PLAIN_MIX_FAST.",
        u_max=6.0, v_max=2.0),
    "aava": Log(
        "n2k/signalk-server__samples__aava-n2k.data",
        "Boat 'Aava', Gulf of Finland (59.7 N 24.7 E), 2014-08-15 19:00Z, 600 s under way "
        "at 3.4 m/s with turns of up to 7.5 deg/s. Heading 127250 at 1 Hz, 129025 and "
        "129029 each 1 Hz from src 160 (129029 repeats 129025's fix 0.5 s later), "
        "COG/SOG 129026 1 Hz; no rate-of-turn sensor.",
        u_max=7.0, v_max=1.5),
    "can0-1": Log(
        "n2k/canboat__samples__can0-1.pcap__DERIVED_candump-l.log",
        "A yacht's bus (Navico, many sources), 2022-11-30, 60 s, still; 0.43 s of frames "
        "stamped 13.9 days early, two gaps > 1 s. Heading src 23 at 20 Hz, rate of turn "
        "src 23 at 20 Hz, position src 21 at 9 Hz first (six GNSS sources).",
        u_max=6.0, v_max=2.0),
    "merrimac-ydwg": Log(
        "n2k/canboat__samples__merrimac-ydwg-2020.raw",
        "Trawler Merrimac, YDWG-02 RAW, 2020-03-04, 2.5 s (date from 126992), still. "
        "Heading/rate src 19 at 20 Hz, position src 45 at 10 Hz.",
        u_max=6.0, v_max=2.0),
    "bundg_zeus_9": Log(
        "nmea0183/gpsd__test__daemon__bundg_zeus_9.log",
        "B&G Zeus2 9 chartplotter, IJsselmeer (no tide) 2018-08-20, 148 s under way at "
        "2.9 m/s. SDHDG magnetic heading with variation at 10 Hz, GGA/RMC/GLL 1 Hz (one "
        "fix three times), RMC/VTG SOG; no rate of turn.",
        u_max=6.0, v_max=1.0, config={"init_window": 3.0}),
    "gofree-merrimac": Log(
        "nmea0183/signalk-server__samples__gofree-merrimac.log",
        "Trawler Merrimac, Navico GoFree TCP, 2014-04-16, 141 s, still. SDHDG at 10 Hz, "
        "GGA/RMC/GLL 1 Hz, RMC/VTG SOG; no rate of turn.",
        u_max=6.0, v_max=2.0, config={"init_window": 3.0}),
    "saab-r4": Log(
        "nmea0183/gpsd__test__daemon__saab-r4.log",
        "A ship's Saab R4 AIS/GPS, 2011-06-01, 11 s at 0.5 kn. HEHDT gyro and HEROT rate "
        "of turn 1 Hz, GGA/RMC/GLL 1 Hz, RMC/VTG SOG.",
        u_max=13.0, v_max=2.0, config={"init_window": 3.0}),
    "skytraq": Log(
        "nmea0183/gpsd__test__daemon__skytraq-PX1172RH_DS.log",
        "SkyTraq PX1172RH_DS dual-antenna RTK heading receiver, 2022-03-29, 8 s, static "
        "(every fix equal). GNHDT and GNTHS 1 Hz, GGA/RMC/GLL 1 Hz; gpsd JSON lines mixed in.",
        u_max=6.0, v_max=2.0, config={"init_window": 3.0}),
    "rst39": Log(
        "nmea0183/gpsd__test__daemon__rst39.log",
        "OxTS GPS/IMU (a land-vehicle INS), 2014-02-19, 4 s turning at 18 deg/s "
        "(HDT 25.5 -> 74.8 deg in 3 s) at 4.6 m/s: a 14 m radius, no ship does this. "
        "GPGGA 10 Hz, GPHDT 1 Hz; PASHR not decoded.",
        u_max=10.0, v_max=2.0),
    "hemi": Log(
        "nmea0183/gpsd__test__daemon__hemi.log",
        "Hemisphere GNSS compass, 2018-09-07, 107 s but mostly without a fix: 21 of 215 "
        "GGA valid, 4 of 215 HDT.",
        u_max=6.0, v_max=2.0),
}

def available(name: str) -> bool:
    return (DATA / LOGS[name].path).is_file()


def dedupe_fixes(ms: list[Measurement]) -> tuple[list[Measurement], int]:
    """One fix once: drop a fix of a source stamped with the same time as the last kept
    one (GGA, RMC and GLL of one second, rounded differently), or equal to it and less
    than 0.9 s after it (Aava's 129029 repeating 129025's fix)."""
    last: dict[str, tuple[float, Any, Any]] = {}
    out, dropped = [], 0
    for m in ms:
        if m.kind == "position":
            key = (m.values.get("lat"), m.values.get("lon"))
            prev = last.get(m.source)
            if prev is not None and (m.t == prev[0] or ((prev[1], prev[2]) == key and m.t - prev[0] < 0.9)):
                dropped += 1
                continue
            if _finite(key[0]) and _finite(key[1]):
                last[m.source] = (m.t, key[0], key[1])
        out.append(m)
    return out, dropped


def spread_same_time(ms: list[Measurement]) -> tuple[list[Measurement], int]:
    """Records of a stream (kind, source) stamped in whole seconds that share a time
    stamp, spread evenly over the interval to the stream's next stamp (at most 1.5 s;
    else the one before). Streams stamped finer (CAN logs: ms) are left alone.

    NMEA 0183 text without per-line times gives every sentence the time of the last
    GGA/RMC/ZDA: Zeus2's ten SDHDG a second all arrive at one instant, ten different
    headings of a turning boat at once. They were sent 0.1 s apart; a live input stamps
    them so (on arrival), and a user replaying the log expects the same."""
    by: dict[tuple[str, str], list[int]] = {}
    for i, m in enumerate(ms):
        by.setdefault((m.kind, m.source), []).append(i)
    new_t = [m.t for m in ms]
    moved = 0
    for (kind, _), idx in by.items():
        if kind == "position":  # one fix a time stamp already (dedupe_fixes)
            continue
        times = [ms[i].t for i in idx]
        distinct = set(times)
        if sum(t == math.floor(t) for t in distinct) < 0.9 * len(distinct):
            continue  # a stream stamped finer than the second (a CAN log's ms bursts)
        j = 0
        prev_span = 1.0
        while j < len(idx):
            k = j
            while k + 1 < len(idx) and times[k + 1] == times[j]:
                k += 1
            n = k - j + 1
            if k + 1 < len(idx) and 0.0 < times[k + 1] - times[j] <= 1.5:
                span = times[k + 1] - times[j]
            else:
                span = prev_span
            if n > 1:
                for q in range(n):
                    new_t[idx[j + q]] = times[j] + span * q / n
                moved += n - 1
            prev_span = span
            j = k + 1
    out = [Measurement(m.kind, m.source, t, m.values) if t != m.t else m for m, t in zip(ms, new_t)]
    out.sort(key=lambda m: m.t)
    return out, moved


@dataclass
class Run:
    name: str
    log: Log
    all_ms: list[Measurement]
    fed: list[Measurement]
    dropped_fixes: int
    spread: int
    core: ManoeuvreCore
    out: list[Estimate]
    cpu: float
    error: str | None = None

    # ------------------------------------------------------------ figures
    def duration(self) -> float:
        """Seconds of data: the intervals between fed records, gaps > GAP left out (the
        can0-1 capture's 0.43 s stamped 13.9 days early is not 13.9 days of data)."""
        t = np.array([m.t for m in self.fed])
        d = np.diff(t)
        return float(d[(d >= 0) & (d <= GAP)].sum()) if len(t) > 1 else 0.0

    def gaps(self) -> int:
        t = np.array([m.t for m in self.fed])
        return int((np.diff(t) > GAP).sum()) if len(t) > 1 else 0

    def counts(self) -> Counter[tuple[str, str]]:
        return Counter((m.kind, m.source.rsplit(".", 1)[-1]) for m in self.all_ms if m.kind in KINDS)

    def fed_sources(self) -> dict[str, str]:
        return {m.kind: m.source.rsplit(".", 1)[-1] for m in self.fed}

    def nis(self, kind: str) -> dict[str, float]:
        """Applied updates of a kind (from core.trace): count, gated, mean NIS / dof,
        the share inside the two-sided 95 % band, the share above its upper end."""
        from scipy.stats import chi2

        rows = [r for r in self.core.trace or [] if r[1] == kind]
        applied = [r for r in rows if r[4]]
        if not applied:
            return {"updates": 0, "gated": len(rows)}
        dof = applied[0][3]
        x = np.array([r[2] for r in applied])
        lo, hi = chi2.ppf(0.025, dof), chi2.ppf(0.975, dof)
        return {
            "updates": len(applied), "gated": len(rows) - len(applied), "dof": dof,
            "mean": float(x.mean()), "median": float(np.median(x)),
            "band": float(np.mean((x >= lo) & (x <= hi))), "above": float(np.mean(x > hi)),
        }

    def series(self, f: str) -> tuple[np.ndarray, np.ndarray]:
        return np.array([e.t for e in self.out]), np.array([e.values[f] for e in self.out], dtype=float)

    def yaw_noise(self) -> dict[str, float] | None:
        """Raw rate of turn against the filtered r on one grid: the raw samples thinned
        to one per >= 0.1 s (the publish interval; a bursty 80 Hz stream or a 1 Hz one
        alike), each beside the first estimate published after it (the one that has
        it). No averaging or interpolation on either side."""
        raw = [m for m in self.fed if m.kind == "yaw_rate" and _finite(m.values.get("r"))]
        if len(raw) < 10 or len(self.out) < 10:
            return None
        te, re_ = self.series("r")
        tr, rr, last = [], [], -math.inf
        for m in raw:
            if te[0] <= m.t <= te[-1] and m.t - last >= TICK - 1e-6:
                tr.append(m.t)
                rr.append(float(m.values["r"]))
                last = m.t
        if len(tr) < 10:
            return None
        a = np.array(rr)
        b = re_[np.clip(np.searchsorted(te, np.array(tr), side="right"), 0, len(te) - 1)]
        da, db = np.diff(a), np.diff(b)
        return {
            "samples": float(len(a)),
            "raw_diff_std": float(da.std()), "filtered_diff_std": float(db.std()),
            "rms_raw_minus_filtered": float(np.sqrt(np.mean((a - b) ** 2))),
            "raw_std": float(a.std()), "max_abs_r": float(np.max(np.abs(re_))),
            "max_abs_raw": float(np.max(np.abs(a))),
        }

    def heading_range(self) -> float:
        """The span of the published heading (rad), unwrapped."""
        _, h = self.series("heading")
        if len(h) == 0:
            return 0.0
        u = np.unwrap(h)
        return float(u.max() - u.min())

    def fix_speed(self, baseline: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
        """The log's own speed where it sends none: fed fixes >= `baseline` s apart,
        distance over time (σ <= 1.5 m·√2/10 s = 0.2 m/s), at the later fix's time."""
        from edged.geo import LocalPlane

        fx = [m for m in self.fed if m.kind == "position" and _finite(m.values.get("lat"))]
        if len(fx) < 2:
            return np.array([]), np.array([])
        plane = LocalPlane(float(fx[0].values["lat"]), float(fx[0].values["lon"]))
        pts = [(m.t, *plane.to_ne(float(m.values["lat"]), float(m.values["lon"]))) for m in fx]
        ts, vs, j = [], [], 0
        for i in range(len(pts)):
            while j + 1 < i and pts[i][0] - pts[j + 1][0] >= baseline:
                j += 1
            dt = pts[i][0] - pts[j][0]
            if dt >= baseline:
                ts.append(pts[i][0])
                vs.append(math.hypot(pts[i][1] - pts[j][1], pts[i][2] - pts[j][2]) / dt)
        return np.array(ts), np.array(vs)

    def sog_check(self) -> dict[str, Any] | None:
        """The published sog beside the log's own SOG (velocity_ground of the first
        source): the estimate published next after each SOG, its σ from std u, v."""
        if len(self.out) < 2:
            return None
        vg = [m for m in self.all_ms if m.kind == "velocity_ground" and _finite(m.values.get("sog"))]
        if vg:
            src = vg[0].source
            vg = [m for m in vg if m.source == src]
            tl = np.array([m.t for m in vg])
            sl = _running_median(np.array([float(m.values["sog"]) for m in vg]), 5)
            what = f"log SOG ({src.rsplit('.', 1)[-1]}, running median of 5)"
        else:
            tl, sl = self.fix_speed()
            what = "fixes' speed over >= 10 s"
            if len(tl) == 0:
                return None
        te, sog = self.series("sog")
        su = np.array([math.hypot(e.values["std"]["u"], e.values["std"]["v"]) for e in self.out])
        keep = (tl >= te[0]) & (tl <= te[-1])
        tl, sl = tl[keep], sl[keep]
        if len(tl) == 0:
            return None
        i = np.clip(np.searchsorted(te, tl - 1e-9), 0, len(te) - 1)
        d = sog[i] - sl
        return {"what": what, "n": len(d), "t": tl, "diff": d, "sigma": su[i], "log_sog": sl,
                "median_abs": float(np.median(np.abs(d))), "max_abs": float(np.max(np.abs(d)))}


def _running_median(x: np.ndarray, n: int) -> np.ndarray:
    """The median of each reading and its n − 1 neighbours (fewer at the ends): a
    receiver's SOG has single-reading spikes (bundg_zeus_9 reads 3.03, 2.26, 3.34 m/s
    in three seconds of steady steaming) that no hull follows; the reference for the
    estimate is the log's SOG without them."""
    h = n // 2
    return np.array([np.median(x[max(0, i - h):i + h + 1]) for i in range(len(x))])


def _finite(x: Any) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)


def run(name: str, log_config: bool = True, **overrides: Any) -> Run:
    """The default core (plus the log's `config` unless told not, plus `overrides`);
    one run per log and config in a session."""
    cfg = {**(LOGS[name].config if log_config else {}), **overrides}
    return _run(name, tuple(sorted(cfg.items())))


@functools.lru_cache(maxsize=None)
def _run(name: str, cfg_items: tuple[tuple[str, Any], ...]) -> Run:
    log = LOGS[name]
    quiet = logging.getLogger("edged")
    saved = quiet.level
    quiet.setLevel(logging.CRITICAL)  # the logs' own faults, once each: not this test's business
    try:
        all_ms = measurements([DATA / log.path], date=log.date)
    finally:
        quiet.setLevel(saved)  # other tests read the log records
    fed, dropped = dedupe_fixes(select(all_ms, KINDS))
    fed, spread = spread_same_time(fed)
    core = ManoeuvreCore(ManoeuvreConfig(type="manoeuvre", **dict(cfg_items)))
    core.trace = []
    out: list[Estimate] = []
    nxt: float | None = None
    error = None
    t0 = time.process_time()
    try:
        for m in fed:
            if nxt is None or m.t - nxt > GAP:
                nxt = math.floor(m.t / TICK) * TICK + TICK
            while m.t >= nxt - 1e-9:
                out += core.tick(nxt)
                nxt = round(nxt + TICK, 6)
            core.step(m)
    except Exception as e:  # reported by the test and the bench, not hidden
        error = f"{type(e).__name__}: {e}"
    return Run(name, log, all_ms, fed, dropped, spread, core, out, time.process_time() - t0, error)


def walk_numbers(obj: Any, path: str = "") -> list[tuple[str, float]]:
    """Every number in a published value, recursively (dicts, lists, tuples)."""
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return []
    if isinstance(obj, (int, float, np.floating, np.integer)):
        return [(path, float(obj))]
    if isinstance(obj, dict):
        return [x for k, v in obj.items() for x in walk_numbers(v, f"{path}.{k}")]
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [x for i, v in enumerate(obj) for x in walk_numbers(v, f"{path}[{i}]")]
    return [(path + f"<{type(obj).__name__}>", float("nan"))]
