"""The dashboard's health parts: each input (sources) with its rates and rejections,
each estimator with its state, NIS statistics and problems, and the outputs.

They read the runtime's 1 Hz health snapshot (DESIGN §6 `health`), never the
components themselves.
"""

from __future__ import annotations

from typing import Any, Mapping

from rich import box
from rich.table import Table
from rich.text import Text

from . import units as u
from .units import DASH
from .view import fresh_health, freshness, get, status, tick


def _input_rates(h: Mapping[str, Any]) -> tuple[str, str]:
    """(measurements per second, messages per second with their unit) of an input."""
    rates = h.get("rates") or {}
    meas = sum(v for k, v in rates.items() if k.startswith("measurements.") and u.num(v) is not None)
    for key, unit in (("lines", "lines"), ("frames", "frames"), ("bst_messages", "BST msgs")):
        if key in rates:
            return u.rate(meas), f"{u.rate(rates[key])} {unit}"
    return u.rate(meas), DASH


def _counted(counters: Mapping[str, Any], prefix: str) -> dict[str, int]:
    return {k[len(prefix):]: int(v) for k, v in sorted(counters.items()) if k.startswith(prefix) and v}


def sources(snapshot: Mapping[str, Any], now: float) -> Table:
    """Each input: state, ok, measurement and message rates, rejections per reason."""
    health, word = fresh_health(snapshot, now)
    names = (get(snapshot.get("health"), "inputs") or {}) if health is None else (health.get("inputs") or {})
    table = Table(title=f"Sources{'' if health is not None else f'  ({word})'}", title_justify="left", expand=True,
                  box=box.SIMPLE_HEAD, show_edge=False, title_style="bold")
    for col in ("input", "type", "state", "health", "meas/s", "msgs/s", "measurements/s by kind", "rejected (reason: count)"):
        table.add_column(col, overflow="fold")
    if not names:
        table.add_row(DASH, DASH, word, DASH, DASH, DASH, DASH, DASH)
    for name, h in names.items():
        if health is None:
            table.add_row(name, h.get("type", DASH), DASH, Text(DASH), DASH, DASH, DASH, DASH)
            continue
        meas, msgs = _input_rates(h)
        rates = h.get("rates") or {}
        kinds = " · ".join(
            f"{k[len('measurements.'):]} {u.rate(v)}" for k, v in sorted(rates.items())
            if k.startswith("measurements.") and u.num(v)
        ) or DASH
        counters = h.get("counters") or {}
        bad = {**_counted(counters, "rejected."), **{f"dropped.{k}": v for k, v in _counted(counters, "dropped.").items()}}
        rejected = Text(", ".join(f"{k}: {v}" for k, v in bad.items()), style="yellow") if bad else Text("none", style="green")
        state = Text(str(h.get("state", DASH)))
        for p in h.get("problems") or []:
            state.append(f"\n{p}", style="red")
        table.add_row(name, str(h.get("type", DASH)), state, tick(h.get("ok")), meas, msgs, kinds, rejected)
    return table


def _innovation(info: Mapping[str, Any]) -> Text:
    """Per measurement kind: mean NIS over its degrees of freedom (≈ 1 when the filter's
    σ are right) and the share inside the 95 % band (≈ 95 %)."""
    text = Text()
    for kind, s in (get(info, "filter", "innovation") or {}).items():
        dof, mean, band = u.num(get(s, "dof")), u.num(get(s, "nis_mean")), u.num(get(s, "in_band_95"))
        window, gated = u.num(get(s, "window")) or 0, u.num(get(s, "gated")) or 0
        if not dof or mean is None:
            part, style = f"{kind} {DASH}", "dim"
        else:
            ratio = mean / dof
            part = f"{kind} {ratio:.2f}" + ("" if band is None else f" {band:.0%}") + (f" gated {gated:.0f}" if gated else "")
            if window < 20:
                style = "dim"  # too few updates to judge
            elif ratio > 5 or (band is not None and band < 0.5):
                style = "red"
            elif ratio > 2 or ratio < 0.2 or (band is not None and band < 0.8):
                style = "yellow"
            else:
                style = "green"
        if text:
            text.append(" · ")
        text.append(part, style=style)
    return text or Text(DASH)


def _notes(h: Mapping[str, Any]) -> Text:
    text = Text()

    def line(s: str, style: str = "") -> None:
        if text:
            text.append("\n")
        text.append(s, style=style)

    for p in h.get("problems") or []:
        line(str(p), "red")
    f = get(h, "info", "filter") or {}
    out = f.get("out") if isinstance(f, Mapping) else None
    if isinstance(out, list):
        line(f"marks out: {', '.join(out) if out else 'none'}", "yellow" if out else "")
    chi2 = u.num(get(f, "rigid", "chi2_per_dof"))
    if chi2 is not None:
        line(f"rigid hull fit χ²/dof {chi2:.2f}{'' if get(f, 'rigid', 'used') else ' (not used)'}")
    rejected = f.get("rejected") if isinstance(f, Mapping) else None
    if isinstance(rejected, Mapping) and rejected:
        line("rejected: " + ", ".join(f"{k} {v}" for k, v in sorted(rejected.items())), "yellow")
    for w in (f.get("warnings") if isinstance(f, Mapping) else None) or []:
        line(str(w), "yellow")
    resets = u.num(f.get("resets")) if isinstance(f, Mapping) else None
    if resets:
        line(f"resets {resets:.0f} (last: {f.get('last_reset') or DASH})", "yellow")
    if h.get("restarts"):
        line(f"restarts {h['restarts']}: {h.get('last_error') or DASH}", "red")
    return text or Text("none", style="green")


def estimators(snapshot: Mapping[str, Any], now: float) -> Table:
    """Each estimator's state, ok, whether its estimate is stale, and its NIS health."""
    health, word = fresh_health(snapshot, now)
    ests = snapshot.get("estimates") or {}
    known = get(snapshot.get("health"), "estimators") or {}
    order = {kind: i for i, kind in enumerate(("stw", "manoeuvre", "draft"))}
    names = sorted(known or ests, key=lambda n: (order.get(str(get(known, n, "type") or n), len(order)), n))
    table = Table(title=f"Estimators{'' if health is not None else f'  ({word})'}", title_justify="left", expand=True,
                  box=box.SIMPLE_HEAD, show_edge=False, title_style="bold")
    for col in ("estimator", "state", "health", "estimate", "est/s", "NIS/dof, in 95 % band", "problems, rejections"):
        table.add_column(col, overflow="fold")
    if not names:
        table.add_row(DASH, word, Text(DASH), DASH, DASH, DASH, DASH)
    for name in names:
        ok, est_word = freshness(ests.get(name), now)
        h = get(health, "estimators", name)
        if not isinstance(h, Mapping):
            table.add_row(name, DASH, Text(DASH), status(ok, est_word), DASH, DASH, DASH)
            continue
        state = str(h.get("state", DASH))
        if get(h, "info", "stale"):
            state += f" (stale {u.seconds(get(h, 'info', 'age'))})"
        table.add_row(
            name, state, tick(h.get("ok")), status(ok, est_word), u.rate(get(h, "rates", "estimates")),
            _innovation(h.get("info") or {}), _notes(h),
        )
    return table


def outputs(snapshot: Mapping[str, Any], now: float) -> Text:
    health, _ = fresh_health(snapshot, now)
    text = Text("outputs: ", style="bold")
    outs = get(health, "outputs") or {}
    if not outs:
        text.append(DASH)
    for i, (name, h) in enumerate(outs.items()):
        c = h.get("counters") or {}
        done = c.get("recorded", c.get("published", c.get("written", 0)))
        text.append(("; " if i else "") + f"{name} {h.get('state', DASH)} ")
        text.append_text(tick(h.get("ok")))
        text.append(f" {done} records")
        if get(h, "info", "file"):
            text.append(f" -> {h['info']['file']}")
        lost = sum(v for k, v in c.items() if k.startswith(("dropped.", "unsent.")))
        if lost:
            text.append(f" ({lost} lost)", style="red")
    return text
