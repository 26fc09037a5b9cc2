"""The table a replay ends with, and what counts as an output's failure in it."""

from __future__ import annotations

from typing import TextIO

from .health import OK_STATES
from .replay import ReplayStats, utc_iso
from .outputhost import OutputHost
from .runtime import Runtime


def _counted(counters: dict[str, int], prefix: str) -> tuple[int, str]:
    """The sum of the counters `prefix.*` and their list ("" when none)."""
    items = sorted((k[len(prefix) + 1:], v) for k, v in counters.items() if k.startswith(prefix + ".") and v)
    return sum(v for _, v in items), ", ".join(f"{k} {v}" for k, v in items)


def output_failure(o: OutputHost, state: str) -> str | None:
    """Why output `o` did not take everything a replay gave it (None when it did).

    `state` is the output's state before the replay stopped it. An output failed when
    it raised (restarted by its supervisor: the batch in hand is lost), was in a failed
    state, stopped on its own (`stops.<state>`: a recorder's full disk or write error)
    or dropped anything (`dropped.<reason>`, `overflow` of its queue)."""
    h = o.health
    c = h.counters
    why = []
    if h.restarts:
        why.append(f"failed {h.restarts} time(s)")
    if state in ("backoff", "failed", "disk_full", "disk_low"):
        why.append(f"ended {state}")
    stops, stop_list = _counted(c, "stops")
    if stops:
        why.append(f"stopped ({stop_list})")
    dropped, _ = _counted(c, "dropped")
    if dropped:
        why.append(f"dropped {dropped}")
    if c.get("overflow"):
        why.append(f"queue overflow {c['overflow']}")
    if not why:
        return None
    err = f": {h.last_error}" if h.last_error else ""
    return "; ".join(why) + err


def _output_line(o: OutputHost, state: str) -> str:
    """One output's counts: records handed to it, and what it made of them (for a
    recorder: messages that reached the file, dropped and rejected, by reason)."""
    c = o.health.counters
    parts = [f"{c.get('written', 0)} records handed over"]
    if "recorded" in c or getattr(o.plugin, "files", None) is not None:
        parts.append(f"{c.get('recorded', 0)} messages recorded")
        for prefix in ("dropped", "rejected"):
            n, items = _counted(c, prefix)
            parts.append(f"{n} {prefix}" + (f" ({items})" if items else ""))
        files = [str(f) for f in getattr(o.plugin, "files", None) or []]
        if files:
            parts.append("into " + ", ".join(files))
    else:
        skip = {"written", "errors"}
        parts += [f"{k} {v}" for k, v in sorted(c.items()) if k not in skip and v]
    err = f" ({o.health.last_error})" if o.health.last_error else ""
    said = f"ok ({state} to the end)" if state in OK_STATES else state
    return f"output {o.name}: {', '.join(parts)}; {said}{err}"




def print_summary(
    rt: Runtime,
    stats: ReplayStats,
    out: TextIO,
    *,
    states: dict[str, str] | None = None,
    interrupted: str | None = None,
) -> None:
    """The table at the end of a replay: per source, every counter its input kept.

    `states`: each output's state before the replay stopped it (its state now is
    `stopped`); `interrupted`: the signal that stopped the replay before its end."""
    states = states or {}
    if interrupted is not None:
        at = utc_iso(rt.clock.now()) if stats.t_first is not None else "its start"
        print(f"replay interrupted at {at} (data time) by {interrupted}", file=out)
        if stats.t_first is not None:
            print(f"replayed {rt.clock.now() - stats.t_first:.1f} s of data", file=out)
    else:
        span = ""
        if stats.t_first is not None and stats.t_last is not None:
            span = f", {stats.t_last - stats.t_first:.1f} s of data"
        print(f"replayed {stats.records} records{span}", file=out)
    if stats.bad_time:
        print(f"records refused by the replay for a time that cannot be true: {stats.bad_time}", file=out)
    if stats.gaps_skipped:
        print(f"gaps in the data skipped instead of waited for (--speed pacing): {stats.gaps_skipped}", file=out)
    for src, (index, now, t) in sorted(stats.stepped_back.items()):
        print(f"time stepped back: {src} by {now - t:.1f} s at its record {index} (to {utc_iso(t)}, after "
              f"{utc_iso(now)}); {stats.behind[src]} of its records behind the replay's clock reached no "
              f"estimator (two logs in one? replay them one at a time)", file=out)
    rows: list[tuple[str, str, int]] = []
    for h in rt.health.components.values():
        if h.role != "input":
            continue
        for k in sorted(h.counters):
            rows.append((h.name, k, h.counters[k]))
    if rows:
        w1 = max(6, *(len(r[0]) for r in rows))
        w2 = max(7, *(len(r[1]) for r in rows))
        print(f"{'source':<{w1}}  {'counter':<{w2}}  {'count':>9}", file=out)
        last = None
        for src, k, v in rows:
            print(f"{(src if src != last else ''):<{w1}}  {k:<{w2}}  {v:>9}", file=out)
            last = src
    if stats.measurements:
        print("measurements by source and kind:", file=out)
        for (src, kind), v in sorted(stats.measurements.items()):
            print(f"  {src:<24} {kind:<18} {v:>9}", file=out)
    for proto, v in sorted(stats.undecodable.items()):
        print(f"records without a decoder ({proto}): {v}", file=out)
    for w in rt.workers:
        print(f"estimator {w.name}: {w.health.counters.get('estimates', 0)} estimates, "
              f"{w.health.counters.get('late', 0)} late, {w.health.counters.get('errors', 0)} errors", file=out)
    for o in rt.outputs:
        print(_output_line(o, states.get(o.name, o.health.state)), file=out)
