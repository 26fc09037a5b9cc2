"""Whether a draft mark may be used: its sensor's status, silence, impossible values,
jumps; and when it may come back.

A mark is *out* of the derived values while any of these holds, and health names it
with the reason:
- `status`: the sensor says fault (1) or out of water (2);
- `silent`: no reading for `silence` seconds of data time;
- `gaps`: more than `max_lost` of its readings lost over the last 10 s, as its frame
  counter says (`lost` in the measurement), else seen as gaps in its own rhythm (the
  lower quartile of its intervals over 2 s, judged from 2 s after its first reading):
  a sensor or a bus dropping frames is failing, and what comes through may be the
  worst of it;
- `frozen`: one value read exactly for FROZEN_SPAN s (each reading then counted and
  not used), until a reading differs;
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
#: A mark's rhythm is the lower quartile of its intervals over the last RHYTHM_WINDOW s
#: of data time (at least RHYTHM_MIN of them), and no reading is counted lost before
#: the mark has been heard that long: a start-up burst (0.1–1.8 ms between the demo's
#: first frames) taken for the sensor's rhythm counted 54,230 lost readings of 17,000
#: and kept every mark out for 20 s. The quartile, not the median: a mark losing two
#: frames in three still has a third of its intervals at its rhythm. A sensor set to a
#: slower rate is believed once three quarters of the window say so.
RHYTHM_WINDOW = 2.0
RHYTHM_MIN = 11
#: Seconds of readings (and at least FROZEN_RUN of them) of exactly one value that make
#: a mark `frozen`: a sensor stuck at its last reading. A 1-mm sensor in a flat calm
#: may repeat itself for seconds; the tide moves it a millimetre in ten.
FROZEN_SPAN = 30.0
FROZEN_RUN = 20
#: The quartile is taken again every this many readings (it moves slowly).
RHYTHM_EVERY = 10


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
        self.interval: float | None = None  # the sensor's own period, s (None: not known yet)
        self.first_t: float | None = None
        self._intervals: deque[tuple[float, float]] = deque()  # (t, interval before it)
        self._since_median = 0
        self.counted = False  # its losses come from its frame counter (`heard`)
        self._last_z: float | None = None
        self._same = 0
        self._same_since = 0.0
        self._lost: deque[tuple[float, int]] = deque()  # (t, readings lost before it), 10 s
        self._lost_sum = 0

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

    def frozen(self, t: float, z: float) -> bool:
        """True once one value has been read exactly, reading after reading, for
        FROZEN_SPAN s: the wave-free mean of such a mark looks perfect (σ 8.5 mm) and
        is nothing. A reading that differs ends it."""
        if z == self._last_z:
            self._same += 1
        else:
            self._last_z, self._same, self._same_since = z, 1, t
        return self._same >= FROZEN_RUN and t - self._same_since >= FROZEN_SPAN

    def drifting(self, t: float, gap: float | None, limit: float, settle: float) -> bool:
        """A good mark `gap` m from what the others expect: True after `settle` s beyond `limit`."""
        if gap is None or abs(gap) <= limit:
            self._drift_since = None
            return False
        self.disagree = gap
        if self._drift_since is None:
            self._drift_since = t
        return t - self._drift_since >= settle

    def heard(self, t: float, counted: int | None = None) -> int:
        """A reading at t; the readings lost since the last one: `counted`, the frame
        counter's, when the sensor sends one (from then on its word alone: a live bus
        delivering frames in bursts under load made 6,000 of 17,000 look lost to the
        rhythm), else the gaps in its rhythm."""
        lost = 0
        if self.first_t is None:
            self.first_t = t
        if counted is not None:
            self.counted = True
            lost = max(0, int(counted))
        elif self.counted:
            pass
        elif self.last_t is not None and t > self.last_t:
            dt = t - self.last_t
            if self.interval is not None and dt >= 1.5 * self.interval:
                lost = max(0, round(dt / self.interval) - 1)
            w = self._intervals
            w.append((t, dt))
            while len(w) > RHYTHM_MIN and w[0][0] < t - RHYTHM_WINDOW:
                w.popleft()
            self._since_median += 1
            if t - self.first_t >= RHYTHM_WINDOW and len(w) >= RHYTHM_MIN and (
                    self.interval is None or self._since_median >= RHYTHM_EVERY):
                self.interval = sorted(d for _, d in w)[len(w) // 4]
                self._since_median = 0
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
