"""NMEA 0183 sentences and TAG blocks: the one encoder of this format.

Each sentence encoder turns arrays of sensor values (SI) into sentences with valid
checksums; the file writer adds the NMEA 4.10 TAG block with the receive time and the
live emitter sends the bare sentence. Resolutions are those of common instruments and
are listed in `RESOLUTION` so that tests know how close a decoded value must be.
Checksums are computed for a whole batch at once (XOR reduction over the joined bytes),
which is what keeps a three-hour log inside its time budget.
"""

from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np

from edged.units import KNOT


Values = Mapping[str, np.ndarray]

#: Resolution of each encoded value in SI (for tests): field -> step.
RESOLUTION: dict[str, dict[str, float]] = {
    "GGA": {"lat": 1e-5 / 60.0, "lon": 1e-5 / 60.0},
    "VTG": {"cog": np.radians(0.01), "sog": 0.001 * KNOT},
    "HDT": {"heading": np.radians(0.01)},
    "ROT": {"r": np.radians(0.01) / 60.0},
    "VBW": {"stw_long": 0.001 * KNOT, "stw_trans": 0.001 * KNOT},
    "VDR": {"set": np.radians(0.1), "drift": 0.01 * KNOT},
    "DPT": {"depth": 0.01},
}


def checksums(bodies: Sequence[str]) -> list[str]:
    """NMEA checksums (XOR of the characters between `$`/`\\` and `*`), two hex digits."""
    if not bodies:
        return []
    raw = np.frombuffer("".join(bodies).encode("ascii"), dtype=np.uint8)
    lengths = np.fromiter((len(b) for b in bodies), dtype=np.int64, count=len(bodies))
    starts = np.concatenate(([0], np.cumsum(lengths)[:-1]))
    xor = np.bitwise_xor.reduceat(raw, starts)
    xor = np.where(lengths == 0, 0, xor)  # reduceat of an empty slice returns the next byte
    return [f"{x:02X}" for x in xor.tolist()]


def sentences(bodies: Sequence[str]) -> list[str]:
    """`$<body>*hh` for every body."""
    return [f"${b}*{c}" for b, c in zip(bodies, checksums(bodies))]


def tag_blocks(t_ms: np.ndarray) -> list[str]:
    """`\\c:<unix seconds>.<ms>*hh\\` TAG blocks for receive times in milliseconds."""
    bodies = [f"c:{s}.{ms:03d}" for s, ms in zip((t_ms // 1000).tolist(), (t_ms % 1000).tolist())]
    return [f"\\{b}*{c}\\" for b, c in zip(bodies, checksums(bodies))]


def _utc_fields(t_ms: np.ndarray) -> list[str]:
    """hhmmss.ss of UNIX milliseconds."""
    cs = (t_ms // 10) % 8_640_000
    h, rem = cs // 360_000, cs % 360_000
    m, rem = rem // 6000, rem % 6000
    return [f"{a:02d}{b:02d}{c // 100:02d}.{c % 100:02d}" for a, b, c in zip(h.tolist(), m.tolist(), rem.tolist())]


def _angle_fields(deg: np.ndarray, width: int, hemis: str) -> tuple[list[str], list[str]]:
    """ddmm.mmmmm / dddmm.mmmmm and N/S or E/W, rounded in integer units (no 60.0 min)."""
    units = np.round(np.abs(deg) * 60.0 * 1e5).astype(np.int64)
    d, m = units // 6_000_000, units % 6_000_000
    text = [f"{a:0{width}d}{b // 100000:02d}.{b % 100000:05d}" for a, b in zip(d.tolist(), m.tolist())]
    hemi = np.where(deg < 0, hemis[1], hemis[0]).tolist()
    return text, hemi


def _deg(rad: np.ndarray, decimals: int) -> list[float]:
    return (np.round(np.degrees(rad), decimals) % 360.0).tolist()


def gga(talker: str, t_ms: np.ndarray, v: Values) -> list[str]:
    lat, ns = _angle_fields(v["lat"], 2, "NS")
    lon, ew = _angle_fields(v["lon"], 3, "EW")
    q = v["fix_quality"].astype(int).tolist()
    sats = v["sats"].astype(int).tolist()
    hdop = v["hdop"].tolist()
    return [
        f"{talker}GGA,{u},{a},{b},{c},{d},{e},{f:02d},{g:.1f},0.0,M,0.0,M,,"
        for u, a, b, c, d, e, f, g in zip(_utc_fields(t_ms), lat, ns, lon, ew, q, sats, hdop)
    ]


def vtg(talker: str, t_ms: np.ndarray, v: Values) -> list[str]:
    kn = (v["sog"] / KNOT).tolist()
    return [f"{talker}VTG,{c:.2f},T,,M,{s:.3f},N,{s * 1.852:.3f},K,A" for c, s in zip(_deg(v["cog"], 2), kn)]


def hdt(talker: str, t_ms: np.ndarray, v: Values) -> list[str]:
    return [f"{talker}HDT,{h:.2f},T" for h in _deg(v["heading"], 2)]


def rot(talker: str, t_ms: np.ndarray, v: Values) -> list[str]:
    return [f"{talker}ROT,{x:.2f},A" for x in (np.degrees(v["r"]) * 60.0).tolist()]


def vbw(talker: str, t_ms: np.ndarray, v: Values) -> list[str]:
    cols = [(v[k] / KNOT).tolist() for k in ("stw_long", "stw_trans", "ground_long", "ground_trans")]
    return [f"{talker}VBW,{a:.3f},{b:.3f},A,{c:.3f},{d:.3f},A" for a, b, c, d in zip(*cols)]


def vdr(talker: str, t_ms: np.ndarray, v: Values) -> list[str]:
    kn = (v["drift"] / KNOT).tolist()
    return [f"{talker}VDR,{s:.1f},T,,M,{d:.2f},N" for s, d in zip(_deg(v["set"], 1), kn)]


def dpt(talker: str, t_ms: np.ndarray, v: Values) -> list[str]:
    return [f"{talker}DPT,{d:.2f},{o:.2f}," for d, o in zip(v["depth"].tolist(), v["offset"].tolist())]


def zda(talker: str, t_ms: np.ndarray, v: Values) -> list[str]:
    days = (t_ms // 86_400_000).astype("datetime64[D]")
    ymd = [str(d).split("-") for d in days.tolist()]
    return [f"{talker}ZDA,{u},{d[2]},{d[1]},{d[0]},00,00" for u, d in zip(_utc_fields(t_ms), ymd)]


#: Sentence encoders by formatter: (talker, UNIX ms, values) -> sentence bodies.
ENCODERS: dict[str, Callable[[str, np.ndarray, Values], list[str]]] = {
    "GGA": gga,
    "VTG": vtg,
    "HDT": hdt,
    "ROT": rot,
    "VBW": vbw,
    "VDR": vdr,
    "DPT": dpt,
    "ZDA": zda,
}
