"""The dashboard's three estimate panels: speed through water beside the Doppler log
and SOG, the manoeuvring state with its predicted track, and the drafts.

Each reads one estimate payload (as Zenoh and MCAP carry it, SI units) and shows it
in a watch officer's units (`units`); a payload that is not fresh shows "—" only.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from edged.estimates import ESTIMATE_KINDS
from edged.geo import LocalPlane

from . import units as u
from .units import DASH
from .view import Payload, fresh_health, freshness, get, pick, rows_panel, status, tick


def stw_panel(snapshot: Mapping[str, Any], now: float) -> Panel:
    """STW beside the Doppler log's reading and SOG, and the log's estimated error."""
    name, est = pick(snapshot.get("estimates") or {}, "stw")
    ok, word = freshness(est, now)
    e: Payload = est if ok and est is not None else {}
    stw, dvl = u.num(e.get("stw")), u.num(e.get("dvl_stw"))
    health, _ = fresh_health(snapshot, now)
    bias = u.speed(e.get("dvl_bias"), signed=True)
    if u.num(e.get("dvl_bias")) is None and ok:
        reason = get(health, "estimators", name, "info", "filter", "dvl", "reason")
        bias = f"{DASH}  ({reason})" if reason else DASH
    elif u.num(e.get("dvl_bias")) is not None:
        bias += f"  {u.pm(get(e, 'dvl_std', 'bias'), u.speed)}"
    scale = DASH if u.num(e.get("dvl_scale")) is None else f"{e['dvl_scale']:.3f}"
    if u.num(e.get("dvl_scale")) is not None and u.num(get(e, "dvl_std", "scale")) is not None:
        scale += f"  ±{get(e, 'dvl_std', 'scale'):.3f}"
    current = DASH
    if u.num(e.get("current")) is not None:
        current = f"{u.speed(e.get('current'))}  toward {u.heading(e.get('current_set'))}"
    rows: list[tuple[str, str | Text]] = [
        ("STW", f"{u.speed(stw)}  {u.pm(e.get('stw_std'))}".rstrip()),
        ("STW, Doppler log", u.speed(dvl)),
        ("SOG", u.speed(e.get("sog"))),
        ("log − STW", DASH if stw is None or dvl is None else u.speed(dvl - stw, signed=True)),
        ("log offset", bias),
        ("log scale", scale),
        ("current", current),
        ("current along", u.speed(e.get("current_along"), signed=True)),
        ("distance", u.distance(e.get("distance"))),
    ]
    return rows_panel(f"Speed through water (est/{name})", status(ok, word), rows)


def _predicted(e: Payload) -> Table:
    """The predicted positions as range and bearing from the estimate's own (easier to
    read than coordinates that differ in their fourth decimal), heading and 1-σ."""
    table = Table(title="predicted track", title_justify="left", box=None, pad_edge=False)
    for col in ("ahead", "from here", "heading", "±1σ major"):
        table.add_column(col, no_wrap=True)
    rows = e.get("predicted") or []
    lat, lon = u.num(e.get("lat")), u.num(e.get("lon"))
    if not rows:
        table.add_row(DASH, DASH, DASH, DASH)
    for p in rows:
        where = DASH
        plat, plon = u.num(p.get("lat")), u.num(p.get("lon"))
        if None not in (lat, lon, plat, plon):
            n, east = LocalPlane(lat, lon).to_ne(plat, plon)  # type: ignore[arg-type]
            where = f"{u.distance(math.hypot(n, east))} at {u.heading(math.atan2(east, n))}"
        dt = u.num(p.get("dt"))
        table.add_row(
            DASH if dt is None else f"+{dt:.0f} s", where, u.heading(p.get("heading")),
            u.distance(p.get("std_major")),
        )
    return table


def manoeuvre_panel(snapshot: Mapping[str, Any], now: float) -> Panel:
    """Surge, sway, yaw rate, heading, drift angle, position and the predicted track."""
    name, est = pick(snapshot.get("estimates") or {}, "manoeuvre")
    ok, word = freshness(est, now)
    e: Payload = est if ok and est is not None else {}
    drift = u.angle(e.get("drift_angle"))
    if u.num(e.get("drift_angle_water")) is not None:
        drift += f"  (through the water {u.angle(e.get('drift_angle_water'))})"
    kinds = "/".join(str(e[k]) for k in ("model", "filter", "mode") if isinstance(e.get(k), str)) or DASH
    rows: list[tuple[str, str | Text]] = [
        ("u, surge", f"{u.speed(e.get('u'), signed=True)}  {u.pm(get(e, 'std', 'u'))}".rstrip()),
        ("v, sway", f"{u.speed(e.get('v'), signed=True)}  {u.pm(get(e, 'std', 'v'))}".rstrip()),
        ("r, yaw rate", u.turn_rate(e.get("r"))),
        ("heading", u.heading(e.get("heading"))),
        ("drift angle", drift),
        ("SOG / COG", DASH if not e else f"{u.speed(e.get('sog'))}  /  {u.heading(e.get('cog'))}"),
        ("position", u.position(e.get("lat"), e.get("lon"))),
        ("filter", DASH if not e else f"{kinds}, NIS {u.rate(e.get('nis'))}"),
    ]
    return rows_panel(f"Manoeuvring (est/{name})", status(ok, word), rows, after=_predicted(e))


def draft_panel(snapshot: Mapping[str, Any], now: float) -> Panel:
    """Each mark's draft, the mean draft, trim, list, deflection, squat and UKC."""
    name, est = pick(snapshot.get("estimates") or {}, "draft")
    ok, word = freshness(est, now)
    health, _ = fresh_health(snapshot, now)
    e: Payload = est if ok and est is not None else {}
    marks = Table(box=None, pad_edge=False)
    for col in ("mark", "draft", "mean", "wave amp.", "sensor"):
        marks.add_column(col, no_wrap=True, justify="left" if col in ("mark", "sensor") else "right")
    all_marks = e.get("marks") or {}
    filled = set(e.get("filled") or [])
    known = ESTIMATE_KINDS["draft"].marks if "draft" in ESTIMATE_KINDS else ()
    for mark in [*known, *(m for m in all_marks if m not in known)]:
        m = all_marks.get(mark) or {}
        if not m and not e:
            marks.add_row(mark, DASH, DASH, DASH, DASH)
            continue
        sensor = tick(m.get("ok")) if m else Text("no reading", style="yellow")
        why = get(health, "estimators", name, "info", "filter", "marks", mark, "why")
        if m and m.get("ok") is False and why:
            sensor = Text(f"✗ {why}", style="yellow" if why in ("starting", "settling") else "bold red")
        if mark in filled:
            sensor.append(" (filled)", style="yellow")
        marks.add_row(mark, u.metres(m.get("draft")), u.metres(m.get("mean")), u.metres(m.get("amplitude")), sensor)
    trim, lst, defl = u.num(e.get("trim")), u.num(e.get("list")), u.num(e.get("deflection"))
    rows: list[tuple[str, str | Text]] = [
        ("mean draft", f"{u.metres(e.get('mean_draft'))}  {u.pm(e.get('mean_draft_std'), u.metres)}".rstrip()),
        ("trim", DASH if trim is None else f"{u.metres(abs(trim))} by the {'stern' if trim >= 0 else 'head'}"),
        ("list", DASH if lst is None else f"{u.metres(abs(lst))} to {'port' if lst >= 0 else 'starboard'}"),
        ("deflection", DASH if defl is None else f"{u.metres(defl, signed=True)} ({'sagging' if defl >= 0 else 'hogging'})"),
        ("squat", f"{u.metres(e.get('squat'))}  {u.pm(e.get('squat_std'), u.metres)}".rstrip()),
        ("UKC", u.metres(e.get("ukc"))),
    ]
    return rows_panel(f"Draft (est/{name})", status(ok, word), rows, before=marks)
