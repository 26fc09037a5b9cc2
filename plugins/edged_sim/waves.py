"""Waves and the hull's response to them: heave, pitch and roll.

Sea states are sums of long-crested regular components (one for a regular sea, a
JONSWAP spectrum cut into components with random phases for an irregular one). The hull
responds quasi-statically in heave and pitch — it follows the elevation and slope
averaged over its length and beam, which is what makes long ships ride through short
waves — and as a damped oscillator in roll, so that beam seas near the roll period
build up. Everything is written with complex amplitudes at the encounter frequency:
the response of one component at one instant is `Re(H·a·e^{iΦ})`.

Directions: `from_deg` is where the waves come from (true), as a mariner reports
them; μ is the propagation direction relative to the bow (0 following, π head seas).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

G = 9.80665


@dataclass(frozen=True)
class Components:
    amplitude: np.ndarray  #: m
    omega: np.ndarray  #: rad/s, absolute frequency
    k: np.ndarray  #: rad/m, deep-water wave number
    toward: np.ndarray  #: rad, propagation direction (true)
    phase: np.ndarray  #: rad, phase at t = 0

    @property
    def size(self) -> int:
        return int(self.amplitude.size)


def _deep(omega: np.ndarray) -> np.ndarray:
    return omega * omega / G


@dataclass(frozen=True)
class Calm:
    def components(self, rng: np.random.Generator) -> Components:
        z = np.zeros(0)
        return Components(z, z, z, z, z)


@dataclass(frozen=True)
class RegularWaves:
    amplitude: float  #: m
    period: float  #: s
    from_deg: float = 0.0

    def components(self, rng: np.random.Generator) -> Components:
        w = np.array([2.0 * np.pi / self.period])
        toward = np.array([np.radians(self.from_deg + 180.0)])
        return Components(np.array([self.amplitude]), w, _deep(w), toward, rng.uniform(0, 2 * np.pi, 1))


@dataclass(frozen=True)
class JonswapWaves:
    """JONSWAP spectrum (γ = 1 is Pierson–Moskowitz) scaled to the significant height."""

    hs: float  #: m, significant wave height
    tp: float  #: s, peak period
    from_deg: float = 0.0
    gamma: float = 3.3
    n: int = 40
    #: Short-crested: each component's direction drawn about the mean with this spread
    #: (deg, 1σ of a normal, the cos-2s spreading's width; 0: long-crested).
    spread_deg: float = 0.0

    def components(self, rng: np.random.Generator) -> Components:
        wp = 2.0 * np.pi / self.tp
        edges = np.linspace(0.5 * wp, 3.0 * wp, self.n + 1)
        dw = np.diff(edges)
        w = edges[:-1] + dw * rng.uniform(0.0, 1.0, self.n)  # random within bins: no repeat period
        sigma = np.where(w <= wp, 0.07, 0.09)
        shape = w**-5 * np.exp(-1.25 * (wp / w) ** 4) * self.gamma ** np.exp(-((w - wp) ** 2) / (2 * sigma**2 * wp**2))
        m0 = np.sum(shape * dw)
        s = shape * (self.hs / 4.0) ** 2 / m0  # Hs = 4·sqrt(m0)
        amp = np.sqrt(2.0 * s * dw)
        toward = np.full(self.n, np.radians(self.from_deg + 180.0))
        phase = rng.uniform(0, 2 * np.pi, self.n)
        if self.spread_deg > 0.0:  # drawn after the phases: a long-crested sea keeps its bytes
            toward = toward + np.radians(self.spread_deg) * rng.standard_normal(self.n)
        return Components(amp, w, _deep(w), toward, phase)


def _sinc(x: np.ndarray) -> np.ndarray:
    return np.sinc(x / np.pi)


def _slope_factor(x: np.ndarray) -> np.ndarray:
    """Mean slope over a hull of half-length L/2, relative to the slope at midships:
    3·(sin x − x·cos x)/x³ with x = k·(L/2)·cos μ (→ 1 for long waves)."""
    x = np.where(np.abs(x) < 1e-3, 1e-3, x)
    return 3.0 * (np.sin(x) - x * np.cos(x)) / x**3


@dataclass(frozen=True)
class Motion:
    """Heave (+ down), pitch (+ bow up), roll (+ starboard down) and their rates."""

    heave: np.ndarray
    pitch: np.ndarray
    roll: np.ndarray
    heave_rate: np.ndarray
    pitch_rate: np.ndarray
    roll_rate: np.ndarray
    heave_acc: np.ndarray


def encounter_frequency(comp: Components, psi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """ω_e = ω − k·U·cos μ per sample (rows) and component (columns)."""
    mu = comp.toward[None, :] - psi[:, None]
    return comp.omega[None, :] - comp.k[None, :] * u[:, None] * np.cos(mu)


def response(
    comp: Components,
    phase: np.ndarray,
    psi: np.ndarray,
    u: np.ndarray,
    length: float,
    beam: float,
    roll_period: float,
    roll_damping: float,
) -> Motion:
    """Hull motion at samples whose component phases are `phase` (samples × comps)."""
    n = psi.size
    if comp.size == 0:
        z = np.zeros(n)
        return Motion(z, z, z, z, z, z, z)
    mu = comp.toward[None, :] - psi[:, None]
    we = encounter_frequency(comp, psi, u)
    k = comp.k[None, :]
    cm, sm = np.cos(mu), np.sin(mu)
    e = comp.amplitude[None, :] * np.exp(1j * phase)
    h_heave = _sinc(k * length * cm / 2.0) * _sinc(k * beam * sm / 2.0)
    h_pitch = -1j * k * cm * _slope_factor(k * length * cm / 2.0)
    rho = np.abs(we) * roll_period / (2.0 * np.pi)
    h_roll = 1j * k * sm * _slope_factor(k * beam * sm / 2.0) / (1.0 - rho**2 + 2j * roll_damping * rho)
    heave_c, pitch_c, roll_c = -h_heave * e, h_pitch * e, h_roll * e
    iw = 1j * we
    return Motion(
        heave=heave_c.real.sum(axis=1),
        pitch=pitch_c.real.sum(axis=1),
        roll=roll_c.real.sum(axis=1),
        heave_rate=(iw * heave_c).real.sum(axis=1),
        pitch_rate=(iw * pitch_c).real.sum(axis=1),
        roll_rate=(iw * roll_c).real.sum(axis=1),
        heave_acc=(iw * iw * heave_c).real.sum(axis=1),
    )


def sea_at(comp: Components, phase: np.ndarray, psi: np.ndarray, x: float, y: float) -> np.ndarray:
    """The sea's elevation (m, + up) at a point x m ahead of and y m to starboard of the
    reference point, per sample: each component's phase there is the reference point's
    less k·(x cos μ + y sin μ) (the crest reaches a point down its path later). A long
    hull in waves of its own length meets them with a phase at each mark: the marks
    then read different seas, which no rigid heave, pitch and roll can give."""
    if comp.size == 0:
        return np.zeros(psi.size)
    mu = comp.toward[None, :] - psi[:, None]
    shift = comp.k[None, :] * (x * np.cos(mu) + y * np.sin(mu))
    return (comp.amplitude[None, :] * np.cos(phase - shift)).sum(axis=1)


@dataclass(frozen=True)
class WaveYaw:
    """The hull's first-order (wave-frequency) yaw: what a small craft's compass and
    rate gyro see on top of the low-frequency manoeuvring yaw.

    Motion superposition (Fossen, *Handbook of Marine Craft Hydrodynamics and Motion
    Control*, 2011, §10.2 and ch. 8.2: total motion = low-frequency manoeuvring model +
    linear wave-frequency response): the yaw is ψ = ψ_LF + ψ_WF, with ψ_WF a
    narrow-band process, here `n` sinusoids of encounter periods drawn uniformly in
    [period_min_s, period_max_s] with random phases and equal shares of the variance,
    ψ_WF(t) = Σ aᵢ·sin(ωᵢt + φᵢ), aᵢ = amplitude/√(2n). `amplitude_deg` is the
    significant amplitude (the mean of the highest third of the swings, 2·RMS for a
    narrow-band Gaussian process, as H_s = 4·RMS is for the sea): the RMS of ψ_WF is
    amplitude/2, and a 12 m yacht in a 1 m sea "yaws ±5° at 3–6 s". The velocity over ground does not follow the wave
    yaw (the hull's inertia against a 3–6 s oscillation): the track, SOG and COG are the
    low-frequency model's and the body-axis velocities turn against the heading, which
    is the wave-frequency sway and surge a sensor fixed to the hull reports
    (u = U·cos ψ_WF, v = −U·sin ψ_WF on a straight course). The roll/pitch/heave
    response stays on the low-frequency heading.
    """

    amplitude_deg: float = 5.0
    period_min_s: float = 3.0
    period_max_s: float = 6.0
    n: int = 6

    def components(self, rng: np.random.Generator) -> "YawComponents":
        w = 2.0 * np.pi / rng.uniform(self.period_min_s, self.period_max_s, self.n)
        a = np.full(self.n, np.radians(self.amplitude_deg) / np.sqrt(2.0 * self.n))
        return YawComponents(a, w, rng.uniform(0.0, 2.0 * np.pi, self.n))


@dataclass(frozen=True)
class YawComponents:
    amplitude: np.ndarray  #: rad
    omega: np.ndarray  #: rad/s (encounter)
    phase: np.ndarray  #: rad at t = 0

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ψ_WF, its rate and its acceleration at run times t (s)."""
        arg = self.omega[None, :] * np.asarray(t, dtype=float)[:, None] + self.phase[None, :]
        s, c = np.sin(arg), np.cos(arg)
        a, w = self.amplitude[None, :], self.omega[None, :]
        return (a * s).sum(axis=1), (a * w * c).sum(axis=1), -(a * w * w * s).sum(axis=1)


#: `edged sim --waves SPEC` forms, for messages.
WAVES_SPEC = "regular:AMPLITUDE,PERIOD[,FROM_DEG] or jonswap:HS,TP[,FROM_DEG]"


def parse_waves(spec: str, default_from_deg: float = 0.0) -> RegularWaves | JonswapWaves:
    """A sea state from `regular:A,T[,FROM]` or `jonswap:HS,TP[,FROM]` (m, s, degrees true).

    A regular sea is given by its amplitude, as `RegularWaves` and the scenarios'
    descriptions have it ("0.4 m / 12 s" is an amplitude of 0.4 m); an irregular one by
    its significant height (Hs = 4·√m0; a regular sea of amplitude a has Hs = 2√2·a).
    FROM defaults to `default_from_deg` (the scenario's). Raises ValueError with a
    message saying what is wrong.
    """
    kind, sep, rest = spec.strip().partition(":")
    kind = kind.strip().lower()
    if not sep or kind not in ("regular", "jonswap"):
        raise ValueError(f"{spec!r} is not {WAVES_SPEC}")
    parts = [p.strip() for p in rest.split(",")]
    if len(parts) not in (2, 3):
        raise ValueError(f"{spec!r}: two or three numbers after {kind}: ({WAVES_SPEC})")
    try:
        nums = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"{spec!r}: not numbers: {rest!r} ({WAVES_SPEC})") from None
    if not all(np.isfinite(nums)):
        raise ValueError(f"{spec!r}: the numbers must be finite")
    height, period = nums[0], nums[1]
    from_deg = nums[2] % 360.0 if len(nums) == 3 else float(default_from_deg)
    if not 0.0 <= height <= 30.0:
        raise ValueError(f"{spec!r}: the {'amplitude' if kind == 'regular' else 'significant height'} "
                         f"must be within 0..30 m, got {height:g}")
    if not 1.0 <= period <= 60.0:
        raise ValueError(f"{spec!r}: the period must be within 1..60 s, got {period:g}")
    if kind == "regular":
        return RegularWaves(height, period, from_deg=from_deg)
    return JonswapWaves(height, period, from_deg=from_deg)
