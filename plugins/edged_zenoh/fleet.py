"""`edged fleet`: the live table of every vessel publishing under `vessel/*`.

`FleetTable` is pure (samples in, text out, time injected) so it is tested without a
network; `run_fleet` wires it to a zenoh session: it first asks every vessel's
queryable for its latest values (a table that is full at once instead of after the
next health beat), then follows `vessel/*/health`, `vessel/*/est/**` and the liveliness
tokens `vessel/*/alive`, redrawing about once a second. With a `FleetRecorder`
(`edged fleet --record DIR`, `fleetrecord`) every sample taken is also recorded, and
the recorder is flushed once a loop (about once a second); what arrived since the last
loop is taken before the session closes.
"""

from __future__ import annotations

import json
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, TextIO

import zenoh

from .zconfig import to_zenoh

__all__ = ["FleetTable", "VesselRow", "run_fleet", "FLEET_KEYS"]

PREFIX = "vessel"
FLEET_KEYS = (f"{PREFIX}/*/health", f"{PREFIX}/*/est/**")
ALIVE_KEY = f"{PREFIX}/*/alive"
#: Seconds without a sample after which a vessel that has no liveliness news is stale.
STALE_AFTER = 5.0


def _bearing(rad: float) -> str:
    """A heading in [0, 360) degrees, rounded first: 359.96° is 000.0, never 360.0."""
    d = round(math.degrees(rad) % 360.0, 1)
    return f"{0.0 if d >= 360.0 else d:05.1f}"


@dataclass
class VesselRow:
    vessel_id: str
    last_seen: float | None = None
    alive: bool | None = None
    stw: float | None = None
    heading: float | None = None
    lat: float | None = None
    lon: float | None = None
    health: dict[str, Any] = field(default_factory=dict)


def _num(obj: Mapping[str, Any], name: str) -> float | None:
    v = obj.get(name)
    if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
        return float(v)
    return None


def _take_stw(row: VesselRow, obj: Mapping[str, Any]) -> None:
    row.stw = _num(obj, "stw")


def _take_manoeuvre(row: VesselRow, obj: Mapping[str, Any]) -> None:
    row.heading = _num(obj, "heading")
    row.lat, row.lon = _num(obj, "lat"), _num(obj, "lon")


def _take_health(row: VesselRow, obj: Mapping[str, Any]) -> None:
    row.health = dict(obj)


#: What each key (after `vessel/<id>/`) contributes to the row.
_TAKERS: dict[str, Callable[[VesselRow, Mapping[str, Any]], None]] = {
    "est/stw": _take_stw,
    "est/manoeuvre": _take_manoeuvre,
    "health": _take_health,
}


def _components_not_running(health: Mapping[str, Any]) -> list[str]:
    """`name:state` of every component the health snapshot says is not ok."""
    out = []
    for group in health.values():
        if not isinstance(group, Mapping):
            continue
        for name, comp in group.items():
            if isinstance(comp, Mapping) and comp.get("ok") is False:
                out.append(f"{name}:{comp.get('state')}")
    return sorted(out)


class FleetTable:
    """Latest known state of each vessel, rendered as a fixed-width text table."""

    def __init__(self, stale_after: float = STALE_AFTER) -> None:
        self.rows: dict[str, VesselRow] = {}
        self.stale_after = stale_after
        self.bad_samples = 0

    def _row(self, vessel_id: str) -> VesselRow:
        row = self.rows.get(vessel_id)
        if row is None:
            row = self.rows[vessel_id] = VesselRow(vessel_id)
        return row

    def update(self, key: str, payload: bytes, now: float) -> None:
        """Take one sample of `vessel/<id>/<rest>`; bad payloads are counted, not fatal."""
        parts = key.split("/", 2)
        if len(parts) < 3 or parts[0] != PREFIX:
            self.bad_samples += 1
            return
        try:
            obj = json.loads(payload)
        except (ValueError, UnicodeDecodeError, RecursionError):  # [[[[… deeper than Python recurses
            obj = None
        if not isinstance(obj, dict):
            self.bad_samples += 1
            return
        row = self._row(parts[1])
        row.last_seen = now
        taker = _TAKERS.get(parts[2])
        if taker is not None:
            taker(row, obj)

    def liveliness(self, key: str, alive: bool, now: float) -> None:
        parts = key.split("/")
        if len(parts) == 3 and parts[0] == PREFIX:
            row = self._row(parts[1])
            row.alive = alive
            if alive and row.last_seen is None:
                row.last_seen = now

    def state(self, row: VesselRow, now: float) -> str:
        if row.alive is False:
            return "offline"
        if row.last_seen is None or now - row.last_seen > self.stale_after:
            return "stale"
        down = _components_not_running(row.health)
        return "ok" if not down else "degraded " + ",".join(down)

    def render(self, now: float) -> str:
        head = f"{'VESSEL':<16} {'LAST SEEN':>10} {'STW m/s':>8} {'HDG deg':>8} {'LAT':>10} {'LON':>11}  STATE"
        lines = [head]
        for vid in sorted(self.rows):
            r = self.rows[vid]
            seen = "-" if r.last_seen is None else f"{max(0.0, now - r.last_seen):.1f} s"
            stw = "-" if r.stw is None else f"{r.stw:.2f}"
            hdg = "-" if r.heading is None else _bearing(r.heading)
            lat = "-" if r.lat is None else f"{r.lat:.5f}"
            lon = "-" if r.lon is None else f"{r.lon:.5f}"
            lines.append(f"{vid:<16} {seen:>10} {stw:>8} {hdg:>8} {lat:>10} {lon:>11}  {self.state(r, now)}")
        if not self.rows:
            lines.append("(no vessel seen yet)")
        return "\n".join(lines) + "\n"


def _drain(sub: Any, take: Callable[[zenoh.Sample], None]) -> None:
    while (sample := sub.try_recv()) is not None:
        take(sample)


def _draw(out: TextIO, clear: str, table: FleetTable, recorder: Any, clock: Callable[[], float]) -> None:
    """One refresh of the table, the recorder's status line under it (its file
    flushed first, so that the line tells what is on disk)."""
    footer = ""
    if recorder is not None:
        recorder.flush()
        footer = recorder.status_line() + "\n"
    out.write(clear + table.render(clock()) + footer + ("" if clear else "\n"))
    out.flush()


def run_fleet(
    cfg: Mapping[str, Any],
    out: TextIO,
    *,
    interval: float = 1.0,
    duration: float | None = None,
    refreshes: int | None = None,
    stop: threading.Event | None = None,
    clock: Callable[[], float] = time.time,
    query_timeout: float = 2.0,
    recorder: Any = None,
) -> int:
    """Follow the fleet until `stop` is set, `duration` passed or `refreshes` drawn.

    `recorder` (a `fleetrecord.FleetRecorder`, opened; its caller closes it) records
    every sample taken, the latest values the query returns included."""
    stop = stop or threading.Event()
    table = FleetTable()
    session = zenoh.open(to_zenoh(cfg, "fleet zenoh configuration"))
    try:
        subs = [session.declare_subscriber(k, zenoh.handlers.FifoChannel(65536)) for k in FLEET_KEYS]
        alive = session.liveliness().declare_subscriber(ALIVE_KEY, zenoh.handlers.FifoChannel(4096), history=True)

        def take(sample: zenoh.Sample) -> None:
            key, data = str(sample.key_expr), sample.payload.to_bytes()
            table.update(key, data, clock())
            if recorder is not None:
                recorder.take(key, data)

        def take_alive(sample: zenoh.Sample) -> None:
            table.liveliness(str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT, clock())

        for key in FLEET_KEYS:
            for reply in session.get(key, timeout=query_timeout):
                if reply.ok is not None:
                    take(reply.ok)
        clear = "\x1b[H\x1b[2J" if getattr(out, "isatty", lambda: False)() else ""
        deadline = None if duration is None else time.monotonic() + duration
        drawn = 0
        while True:
            for sub in subs:
                _drain(sub, take)
            _drain(alive, take_alive)
            _draw(out, clear, table, recorder, clock)
            drawn += 1
            if refreshes is not None and drawn >= refreshes:
                break
            wait = interval if deadline is None else min(interval, deadline - time.monotonic())
            if wait <= 0 or stop.wait(wait):
                break
        if recorder is not None:  # what arrived during the last wait is recorded too
            for sub in subs:
                _drain(sub, take)
    finally:
        session.close()
    return 0
