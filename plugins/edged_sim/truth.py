"""Everything the estimators estimate, evaluated at any instant of a simulated chunk.

One function computes every truth quantity from the interpolated ship state, the
current, the waves and the loading plan, so the sensors and `truth.csv` can never
disagree about what was true: a sensor is the truth at its own instant plus its errors.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from edged.angles import wrap_2pi
from edged.geo import LocalPlane

from .dynamics import Trace
from .environment import Current, Water, barrass_squat
from .ship import ShipParticulars
from .waves import Components, Motion, YawComponents, encounter_frequency, response, sea_at

#: Draft marks in DBC order (ids 0x310..0x315): (name, x as fraction of L, y side).
MARKS: tuple[tuple[str, float, float], ...] = (
    ("fore_port", 0.5, -1.0),
    ("fore_stbd", 0.5, 1.0),
    ("mid_port", 0.0, -1.0),
    ("mid_stbd", 0.0, 1.0),
    ("aft_port", -0.5, -1.0),
    ("aft_stbd", -0.5, 1.0),
)


@dataclass(frozen=True)
class Loading:
    """The static floating position: mean draft over time (cargo work), trim, list,
    hull deflection; and where the echo sounder's transducer sits."""

    draft_knots: tuple[tuple[float, float], ...] = ((0.0, 8.5),)  #: (t s, mean draft m)
    trim: float = 0.0  #: m, aft − fore, + by the stern
    list: float = 0.0  #: m, port − starboard
    deflection: float = 0.0  #: m, mid − mean(fore, aft), + sagging
    transducer_x: float = 0.3  #: fraction of L ahead of midships
    roll_period: float = 14.0  #: s, natural roll period
    roll_damping: float = 0.1  #: fraction of critical

    def mean_draft(self, t: np.ndarray) -> np.ndarray:
        kt, kd = zip(*self.draft_knots)
        return np.interp(t, kt, kd)


#: truth.csv columns in order (besides the per-mark ones appended by `columns()`).
BASE_COLUMNS = (
    "t", "t_rel", "lat", "lon", "x", "y", "u", "v", "r", "heading", "a_u", "a_v",
    "sog", "cog", "drift_angle", "stw", "stw_long", "stw_trans",
    "current_set", "current_drift", "current_along", "current_cross",
    "ax", "ay", "az", "roll", "pitch", "heave", "roll_rate", "pitch_rate",
    "rudder", "rudder_order", "thrust_speed",
    "depth", "depth_below_transducer", "squat", "ukc",
    "mean_draft", "trim", "list", "deflection",
)


def columns() -> tuple[str, ...]:
    marks = tuple(c for name, _, _ in MARKS for c in (f"draft_{name}", f"draft_{name}_mean"))
    return BASE_COLUMNS + marks


@dataclass
class TruthModel:
    """Truth over consecutive chunks: carries the current's displacement and the
    waves' phases from one chunk to the next."""

    ship: ShipParticulars
    current: Current
    water: Water
    loading: Loading
    waves: Components
    frame: LocalPlane
    epoch: float
    #: The hull's wave-frequency yaw (`waves.WaveYaw`), None for none.
    yaw: YawComponents | None = None
    #: The draft marks read the sea at their own positions (a pressure sensor on a hull:
    #: its depth below the local surface), not only the hull's rigid motion.
    marks_read_sea: bool = False
    _disp: tuple[float, float] = (0.0, 0.0)
    _phase: np.ndarray | None = None
    _chunk: dict = field(default_factory=dict)

    def begin(self, trace: Trace) -> None:
        """Prepare a chunk: current displacement and wave phases on its grid."""
        dn, de = self.current.displacement(trace.t)
        self._chunk = {
            "trace": trace,
            "dn": dn + self._disp[0],
            "de": de + self._disp[1],
        }
        self._disp = (float(self._chunk["dn"][-1]), float(self._chunk["de"][-1]))
        psi, u = trace.s[:, 4], trace.s[:, 2]
        we = encounter_frequency(self.waves, psi, u)
        start = self.waves.phase if self._phase is None else self._phase
        steps = 0.5 * (we[1:] + we[:-1]) * trace.dt
        phase = start[None, :] + np.vstack([np.zeros((1, we.shape[1])), np.cumsum(steps, axis=0)])
        self._chunk["phase"], self._chunk["we"] = phase, we
        self._phase = phase[-1] if phase.shape[0] else start

    def sample(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """Every truth quantity at run times t (s), which must lie in the chunk."""
        ck = self._chunk
        trace: Trace = ck["trace"]
        t = np.asarray(t, dtype=float)
        s, f = trace.hermite(t)
        i, tau = trace.locate(t)
        ship = self.ship
        n_w, e_w, u_r, v_r, psi, r, delta = s.T
        u_dot, v_dot = f[:, 2], f[:, 3]
        vcn, vce, acn, ace = self.current.velocity(t)
        h = trace.dt
        north, east = self._over_ground(i, tau, n_w, e_w)

        c, sn = np.cos(psi), np.sin(psi)
        u_c, v_c = vcn * c + vce * sn, -vcn * sn + vce * c
        u_g, v_g = u_r + u_c, v_r + v_c
        a_u = u_dot + r * v_c + acn * c + ace * sn
        a_v = v_dot - r * u_c - acn * sn + ace * c
        vn_g, ve_g = u_g * c - v_g * sn, u_g * sn + v_g * c
        sog = np.hypot(vn_g, ve_g)
        cog = wrap_2pi(np.arctan2(ve_g, vn_g))
        course_n, course_e = np.cos(cog), np.sin(cog)
        lat, lon = self.frame.to_geodetic_array(north, east)

        wave_phase = ck["phase"][i] + ck["we"][i] * (tau[:, None] * h) + 0.5 * (ck["we"][i + 1] - ck["we"][i]) * h * tau[:, None] ** 2
        lo = self.loading
        mo = response(self.waves, wave_phase, psi, u_r, ship.length, ship.beam, lo.roll_period, lo.roll_damping)

        static = lo.mean_draft(t)
        stw = np.hypot(u_r, v_r)
        squat = barrass_squat(stw, static, ship.beam, ship.block_coefficient, self.water)
        heading = psi
        if self.yaw is not None:
            heading, u_g, v_g, u_r, v_r, r, a_u, a_v = _wave_yawed(self.yaw, t, psi, u_g, v_g, u_r, v_r, r, a_u, a_v)
        out: dict[str, np.ndarray] = {
            "t": self.epoch + t, "t_rel": t, "lat": lat, "lon": lon, "x": north, "y": east,
            "u": u_g, "v": v_g, "r": r, "heading": wrap_2pi(heading), "a_u": a_u, "a_v": a_v,
            "sog": sog, "cog": cog, "drift_angle": np.arctan2(v_g, u_g),
            "stw": stw, "stw_long": u_r, "stw_trans": v_r,
            "current_set": wrap_2pi(np.arctan2(vce, vcn)), "current_drift": np.hypot(vcn, vce),
            "current_along": vcn * course_n + vce * course_e,
            "current_cross": -vcn * course_e + vce * course_n,
            "ax": a_u - v_g * r, "ay": a_v + u_g * r, "az": mo.heave_acc,
            "roll": mo.roll, "pitch": mo.pitch, "heave": mo.heave,
            "roll_rate": mo.roll_rate, "pitch_rate": mo.pitch_rate,
            "rudder": delta, "rudder_order": trace.orders[i, 0], "thrust_speed": trace.orders[i, 1],
            "squat": squat,
        }
        self._marks(out, t, static, squat, mo, wave_phase, psi)
        return out

    def _over_ground(self, i: np.ndarray, tau: np.ndarray, n_w: np.ndarray,
                     e_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """North, east (m): the track through the water plus the current's displacement,
        a Hermite interpolation with the current's velocity as its derivative."""
        ck = self._chunk
        trace: Trace = ck["trace"]
        h = trace.dt
        vn0, ve0, _, _ = self.current.velocity(trace.t[i])
        vn1, ve1, _, _ = self.current.velocity(trace.t[i + 1])
        t2, t3 = tau * tau, tau**3
        b = (2 * t3 - 3 * t2 + 1, (t3 - 2 * t2 + tau) * h, -2 * t3 + 3 * t2, (t3 - t2) * h)
        north = n_w + b[0] * ck["dn"][i] + b[1] * vn0 + b[2] * ck["dn"][i + 1] + b[3] * vn1
        east = e_w + b[0] * ck["de"][i] + b[1] * ve0 + b[2] * ck["de"][i + 1] + b[3] * ve1
        return north, east

    def _marks(self, out: dict[str, np.ndarray], t: np.ndarray, static: np.ndarray, squat: np.ndarray,
               mo: Motion, wave_phase: np.ndarray, psi: np.ndarray) -> None:
        """The draft columns of `out`: each mark's reading and mean, the mean draft,
        trim, list, deflection, depths and the under-keel clearance."""
        ship, lo = self.ship, self.loading
        means = []
        for name, fx, side in MARKS:
            x, y = fx * ship.length, side * ship.beam / 2.0
            mean = static - 2.0 * fx * lo.trim / 2.0 - side * lo.list / 2.0 + squat
            if fx == 0.0:
                mean = mean + lo.deflection
            out[f"draft_{name}_mean"] = mean
            out[f"draft_{name}"] = mean + mo.heave - x * mo.pitch + y * mo.roll
            if self.marks_read_sea:
                out[f"draft_{name}"] = out[f"draft_{name}"] + sea_at(self.waves, wave_phase, psi, x, y)
            means.append(mean)
        fore = 0.5 * (out["draft_fore_port_mean"] + out["draft_fore_stbd_mean"])
        aft = 0.5 * (out["draft_aft_port_mean"] + out["draft_aft_stbd_mean"])
        mid = 0.5 * (out["draft_mid_port_mean"] + out["draft_mid_stbd_mean"])
        port = np.mean([out[f"draft_{n}_mean"] for n, _, sd in MARKS if sd < 0], axis=0)
        stbd = np.mean([out[f"draft_{n}_mean"] for n, _, sd in MARKS if sd > 0], axis=0)
        out["mean_draft"] = np.mean(means, axis=0)
        out["trim"], out["list"], out["deflection"] = aft - fore, port - stbd, mid - 0.5 * (fore + aft)
        xt = lo.transducer_x * ship.length
        draft_tr = static - lo.transducer_x * lo.trim + squat + mo.heave - xt * mo.pitch
        depth = np.full_like(t, self.water.depth)
        out["depth"], out["depth_below_transducer"] = depth, depth - draft_tr
        out["ukc"] = depth - np.max(means, axis=0)


def _wave_yawed(yaw: YawComponents, t: np.ndarray, psi: np.ndarray, u_g: np.ndarray, v_g: np.ndarray,
                u_r: np.ndarray, v_r: np.ndarray, r: np.ndarray, a_u: np.ndarray,
                a_v: np.ndarray) -> tuple[np.ndarray, ...]:
    """The body-axis truth of a hull that yaws by ψ_WF about its low-frequency heading
    while its velocity over ground (and through the water) stays the low-frequency
    model's (`waves.WaveYaw`): heading ψ + ψ_WF, r + ψ̇_WF, the velocities and the
    specific force (what the accelerometers read) turned by −ψ_WF into the yawed
    hull's axes, and a_u, a_v from the specific force with the total r (ax = a_u − v·r,
    ay = a_v + u·r hold as they do without waves)."""
    pw, rw, _ = yaw.at(t)
    cw, sw = np.cos(pw), np.sin(pw)

    def turn(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return x * cw + y * sw, -x * sw + y * cw

    fx, fy = turn(a_u - v_g * r, a_v + u_g * r)
    u_g, v_g = turn(u_g, v_g)
    u_r, v_r = turn(u_r, v_r)
    r = r + rw
    return psi + pw, u_g, v_g, u_r, v_r, r, fx + v_g * r, fy - u_g * r
