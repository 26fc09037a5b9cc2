"""Sensor suites: which instruments a scenario carries, at what rates, how good.

`reference_suite` is DESIGN §9's reference load (drafts at 100 Hz, IMU at 50 Hz, GNSS,
heading and rate of turn at 10 Hz, Doppler log at 1 Hz, a current forecast every 20
minutes) plus the same quantities on NMEA 2000, so that every PGN the CAN input reads
is exercised. `stw_suite` is the STW paper's set-up at realistic instrument rates
(the estimator may thin them out to the paper's 30 s).
"""

from __future__ import annotations

import math

from .sensors import SensorSpec
from .truth import MARKS

DEG = math.pi / 180.0
FORECAST_HZ = 1.0 / 1200.0  #: a hindcast/forecast provider's 20 minutes


def gnss(rate: float, position_sigma: float = 1.5, velocity_sigma: float = 0.05) -> tuple[SensorSpec, ...]:
    return (
        SensorSpec("gnss1.position", "position", rate, ("nmea:GGA",), noise={"position": position_sigma}, talker="GP"),
        SensorSpec("gnss1.velocity", "velocity_ground", rate, ("nmea:VTG",), noise={"velocity": velocity_sigma},
                   talker="GP", offset_ms=2),
        SensorSpec("gnss1.time", "time", 1.0, ("nmea:ZDA",), talker="GP", offset_ms=3),
    )


def n2k_gnss(rate: float, position_sigma: float = 1.5, velocity_sigma: float = 0.05) -> tuple[SensorSpec, ...]:
    return (
        SensorSpec("gnss2.rapid", "position", rate, ("n2k:129025",), noise={"position": position_sigma},
                   address=28, offset_ms=5),
        SensorSpec("gnss2.velocity", "velocity_ground", rate, ("n2k:129026",), noise={"velocity": velocity_sigma},
                   address=28, offset_ms=6),
        SensorSpec("gnss2.position", "position", 1.0, ("n2k:129029",), noise={"position": position_sigma},
                   address=28, offset_ms=7),
    )


def gyro(rate: float) -> tuple[SensorSpec, ...]:
    return (
        SensorSpec("gyro.heading", "heading", rate, ("nmea:HDT", "n2k:127250"), noise={"heading": 0.1 * DEG},
                   talker="HE", address=18, offset_ms=1),
        SensorSpec("gyro.rot", "yaw_rate", rate, ("nmea:ROT", "n2k:127251"), noise={"r": 0.02 * DEG},
                   talker="HE", address=18, offset_ms=4),
    )


def imu(rate: float, attitude_rate: float = 10.0) -> tuple[SensorSpec, ...]:
    """A MEMS/FOG unit: accelerations (gravity removed) and rates on the DBC frames."""
    acc = {"ax": 0.02, "ay": 0.02, "az": 0.02}
    return (
        SensorSpec("imu.accel", "imu_accel", rate, ("dbc:ImuAccel",), noise=acc, bias={"ax": 0.005, "ay": -0.003},
                   offset_ms=8),
        SensorSpec("imu.rate", "imu_rate", rate, ("dbc:ImuRate",),
                   noise={"r": 0.005 * DEG, "roll_rate": 0.01 * DEG, "pitch_rate": 0.01 * DEG}, offset_ms=9),
        SensorSpec("imu.attitude", "attitude", attitude_rate, ("dbc:ImuAttitude", "n2k:127257"),
                   noise={"roll": 0.02 * DEG, "pitch": 0.02 * DEG, "heave": 0.02, "yaw": 0.1 * DEG},
                   address=45, offset_ms=11),
    )


def dvl(offset: float = 0.3) -> SensorSpec:
    """A Doppler log that reads `offset` m/s high: the error the STW estimator exists for."""
    return SensorSpec("dvl", "water_speed", 1.0, ("nmea:VBW",), noise={"stw_long": 0.05, "stw_trans": 0.05},
                      bias={"stw_long": offset}, talker="VD", offset_ms=12)


def forecast(sigma: float = 0.2) -> SensorSpec:
    """Current forecasts every 20 minutes (seed 000: σ 0.2 m/s)."""
    return SensorSpec("forecast", "current", FORECAST_HZ, ("nmea:VDR",),
                      noise={"velocity": sigma}, talker="II", offset_ms=13)


def echo_sounder(offset: float) -> SensorSpec:
    return SensorSpec("echo", "depth", 1.0, ("nmea:DPT",), noise={"depth": 0.05}, bias={"offset": offset},
                      quantum={"depth": 0.01}, talker="SD", offset_ms=14)


def draft_marks(rate: float = 100.0, sigma: float = 0.1) -> tuple[SensorSpec, ...]:
    """Six draft sensors (seed 003: 100 Hz; σ 0.1 m in the reference scenarios)."""
    return tuple(
        SensorSpec(f"draft.{name}", "draft", rate, ("dbc:DraftMark",), noise={"draft": sigma}, mark=name)
        for name, _, _ in MARKS
    )


def reference_suite(draft_offset: float, drafts: bool = True) -> tuple[SensorSpec, ...]:
    marks = draft_marks() if drafts else ()
    return gnss(10.0) + n2k_gnss(10.0) + gyro(10.0) + imu(50.0) + (dvl(), forecast(), echo_sounder(draft_offset)) + marks


def stw_suite(draft_offset: float) -> tuple[SensorSpec, ...]:
    return gnss(1.0, position_sigma=2.5, velocity_sigma=0.065) + n2k_gnss(1.0, 2.5, 0.065) + gyro(1.0) + (
        SensorSpec("imu.accel", "imu_accel", 10.0, ("dbc:ImuAccel",), noise={"ax": 0.05, "ay": 0.05, "az": 0.05},
                   offset_ms=8),
        dvl(0.3), forecast(0.2), echo_sounder(draft_offset),
    )
