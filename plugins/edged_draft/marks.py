"""Whether a draft mark may be used: its sensor's status, silence, impossible values,
jumps; and when it may come back.

A mark is *out* of the derived values while any of these holds, and health names it
with the reason:
- `status`: the sensor says fault (1) or out of water (2);
- `silent`: no reading for `silence` seconds of data time;
- `gaps`: more than `max_lost` of its readings lost over the last 10 s, seen as gaps in
  its own rhythm (what the CAN counter says, from any source): a sensor or a bus
  dropping frames is failing, and what comes through may be the worst of it;
- `range`: `jump_after` readings in a row outside [min_draft, max_draft] (each one
  counted and not used: a single spike does not put the mark out);
- `jumped`: most of its last `jump_after` readings beyond the filter's gate (in a row
  is not enough: a jump of 5σ lets one reading in ten through, and each pulls the
  filter toward it). The filter starts again from the new readings;
- `disagrees`: its mean is more than 1.5 × `agree` m from what its partner and the
  list at the other stations say, for two seconds (a jump the gate lets through one
  reading in ten of, which the filter then follows; a drift). Of a pair, the one the
  gate has stopped more often lately;
- `settling`: back from any of these, until `settle` seconds have passed and its mean
  agrees with what its partner and the list at the other stations say (within `agree`
  m): a mark that came back wrong stays out and says by how much.
"""

from __future__ import annotations

from collections import Counter, deque

#: Seconds over which a mark's lost readings are counted.
LOST_WINDOW = 10.0
#: Gaps in a row after which the sensor is taken to run at a slower rate (losses are
#: irregular: a steady rhythm is the sensor's).
RATE_CHANGE = 200


class MarkState:
    def __init__(self, name: str) -> None:
        self.name = name
        self.last_t: float | None = None
        self.status = 0
        self.gated_share = 0.0  # running share of gated readings over about jump_after
        self.gated_lately = 0.0  # the same over about a minute at 100 Hz
        self.readings = 0
        self.range_in_row = 0
        self.first = True  # the start is not a return
        self._drift_since: float | None = None
        self.reason: str | None = "starting"
        self.back_since: float | None = None
        self.disagree: float | None = None
        self.counts: Counter[str] = Counter()
        self.interval: float | None = None  # the sensor's own period, s
        self._lost: deque[tuple[float, int]] = deque()  # (t, readings lost before it), 10 s
        self._lost_sum = 0
        self._gaps_in_row = 0

    @property
    def ok(self) -> bool:
        return self.reason is None

    def out(self, reason: str) -> None:
        if self.reason != reason:
            self.counts[f"out.{reason}"] += 1
        self.reason = reason
        self.back_since = None

    def gated(self, was_gated: bool, span: int) -> bool:
        """One reading judged by the gate; True when the mark has jumped."""
        self.readings += 1
        a = 1.0 / min(self.readings, span)
        g = 1.0 if was_gated else 0.0
        self.gated_share += a * (g - self.gated_share)
        self.gated_lately += (g - self.gated_lately) / 6000.0
        if self.readings >= span and self.gated_share > 0.5:
            self.gated_share = 0.0
            self.readings = 0
            return True
        return False

    def drifting(self, t: float, gap: float | None, limit: float, settle: float) -> bool:
        """A good mark `gap` m from what the others expect: True after `settle` s beyond `limit`."""
        if gap is None or abs(gap) <= limit:
            self._drift_since = None
            return False
        self.disagree = gap
        if self._drift_since is None:
            self._drift_since = t
        return t - self._drift_since >= settle

    def heard(self, t: float) -> int:
        """A reading at t; the readings lost since the last one (gaps in its rhythm)."""
        lost = 0
        if self.last_t is not None and t > self.last_t:
            dt = t - self.last_t
            if self.interval is None:
                self.interval = dt
            elif dt < 1.5 * self.interval:
                self.interval += 0.01 * (dt - self.interval)
                self._gaps_in_row = 0
            else:
                lost = max(0, round(dt / self.interval) - 1)
                self._gaps_in_row += 1
                if self._gaps_in_row >= RATE_CHANGE:  # no reading on time for 200: a new rate
                    self.interval, self._gaps_in_row, lost = dt, 0, 0
        self.last_t = t
        q = self._lost
        q.append((t, lost))
        self._lost_sum += lost
        while q and q[0][0] < t - LOST_WINDOW:
            self._lost_sum -= q.popleft()[1]
        return lost

    @property
    def lost_share(self) -> float:
        """Of the readings due over the last 10 s, the share lost."""
        n = len(self._lost)
        return self._lost_sum / (self._lost_sum + n) if n else 0.0

    def check_silence(self, t: float, silence: float) -> None:
        if self.last_t is not None and t - self.last_t > silence and self.reason not in ("status",):
            self.out("silent")

    def settle(self, t: float) -> None:
        """A reading was used: a mark that was out starts settling."""
        if self.reason is not None and self.reason != "settling":
            self.reason = "settling"
            self.back_since = t

    def judge(self, t: float, settle: float, agree: float, mean: float, expected: float | None) -> None:
        """A settling mark is back when it has settled `settle` seconds and agrees with
        what the others expect of it (`derived.fill`; nothing to compare with: back)."""
        if self.reason != "settling" or self.back_since is None or t - self.back_since < settle:
            return
        gap = None if expected is None else mean - expected
        self.disagree = gap
        if gap is None or abs(gap) <= agree:
            self.reason = None
            self.back_since = None
            self._drift_since = None
            if not self.first:
                self.counts["back"] += 1
            self.first = False
