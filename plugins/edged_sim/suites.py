"""Sensor suites: which instruments a scenario carries, at what rates, how good.

`reference_suite` is DESIGN §9's reference load (drafts at 100 Hz, IMU at 50 Hz, GNSS,
heading and rate of turn at 10 Hz, Doppler log at 1 Hz, a current forecast every 20
minutes) plus the same quantities on NMEA 2000, so that every PGN the CAN input reads
is exercised. `stw_suite` is the STW paper's set-up at realistic instrument rates
(the estimator may thin them out to the paper's 30 s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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


# -- suites as parameters (issue 30: one default configuration for every suite) ---------
@dataclass(frozen=True)
class SuiteSpec:
    """A sensor suite by its qualities, from a yacht's to a large ship's.

    Ranges seen aboard (ESTIMATORS.md, "What the world adds"): GNSS from 10 Hz to a fix
    every 30 s, compasses from a 0.05° satellite compass to a 1° fluxgate, rate gyros
    from a 0.001 °/s fibre-optic gyro to a 0.1 °/s MEMS, IMUs from none to 50 Hz, and a
    second compass that disagrees (a magnetic or deviated one).
    The GNSS goes out on NMEA 0183 (GGA, VTG) and NMEA 2000 (129025, 129026 at its
    period; 129029 at most once a second); the compass on HDT and 127250 and the rate
    gyro on ROT and 127251 (one instrument, two buses, the same values); the IMU on the
    reference DBC frames, its yaw-rate channel as good as the rate gyro.
    """

    name: str
    description: str
    gnss_period_s: float = 1.0
    position_sigma: float = 1.5  #: m, per axis
    velocity_sigma: float = 0.05  #: m/s, per axis of the velocity vector
    heading_hz: float = 10.0
    heading_sigma_deg: float = 0.1
    gyro_sigma_deg_s: float | None = 0.02  #: None: no rate-of-turn sensor
    gyro_hz: float = 10.0
    imu_hz: float | None = 50.0  #: None: no IMU
    #: A second compass on NMEA 2000 (address 19, PGN 127250) reading this many degrees
    #: more than the truth (a deviated magnetic compass); None: none.
    second_compass_deg: float | None = None
    second_compass_sigma_deg: float = 0.5
    dvl_offset: float | None = 0.3  #: m/s, the log's error; None: no log
    forecast_sigma: float | None = 0.2  #: m/s, current forecasts every 20 minutes; None: none

    def sensors(self) -> tuple[SensorSpec, ...]:
        """The suite's instruments, in a fixed order (each draws from its own stream)."""
        rate = 1.0 / self.gnss_period_s
        pos, vel = {"position": self.position_sigma}, {"velocity": self.velocity_sigma}
        out: list[SensorSpec] = [
            SensorSpec("gnss1.position", "position", rate, ("nmea:GGA",), noise=pos, talker="GP"),
            SensorSpec("gnss1.velocity", "velocity_ground", rate, ("nmea:VTG",), noise=vel, talker="GP", offset_ms=2),
            SensorSpec("gnss1.time", "time", min(rate, 1.0), ("nmea:ZDA",), talker="GP", offset_ms=3),
            SensorSpec("gnss2.rapid", "position", rate, ("n2k:129025",), noise=pos, address=28, offset_ms=5),
            SensorSpec("gnss2.velocity", "velocity_ground", rate, ("n2k:129026",), noise=vel, address=28,
                       offset_ms=6),
            SensorSpec("gnss2.position", "position", min(rate, 1.0), ("n2k:129029",), noise=pos, address=28,
                       offset_ms=7),
            SensorSpec("gyro.heading", "heading", self.heading_hz, ("nmea:HDT", "n2k:127250"),
                       noise={"heading": self.heading_sigma_deg * DEG}, talker="HE", address=18, offset_ms=1),
        ]
        if self.gyro_sigma_deg_s is not None:
            out.append(SensorSpec("gyro.rot", "yaw_rate", self.gyro_hz, ("nmea:ROT", "n2k:127251"),
                                  noise={"r": self.gyro_sigma_deg_s * DEG}, talker="HE", address=18, offset_ms=4))
        if self.imu_hz is not None:
            r_sigma = (self.gyro_sigma_deg_s if self.gyro_sigma_deg_s is not None else 0.1) * DEG
            out += [
                SensorSpec("imu.accel", "imu_accel", self.imu_hz, ("dbc:ImuAccel",),
                           noise={"ax": 0.02, "ay": 0.02, "az": 0.02}, bias={"ax": 0.005, "ay": -0.003}, offset_ms=8),
                SensorSpec("imu.rate", "imu_rate", self.imu_hz, ("dbc:ImuRate",),
                           noise={"r": r_sigma, "roll_rate": 0.01 * DEG, "pitch_rate": 0.01 * DEG}, offset_ms=9),
                SensorSpec("imu.attitude", "attitude", min(self.imu_hz, 10.0), ("dbc:ImuAttitude", "n2k:127257"),
                           noise={"roll": 0.02 * DEG, "pitch": 0.02 * DEG, "heave": 0.02,
                                  "yaw": self.heading_sigma_deg * DEG}, address=45, offset_ms=11),
            ]
        if self.second_compass_deg is not None:
            out.append(SensorSpec("compass2.heading", "heading", self.heading_hz, ("n2k:127250",),
                                  noise={"heading": self.second_compass_sigma_deg * DEG},
                                  bias={"heading": self.second_compass_deg * DEG}, address=19, offset_ms=15))
        if self.dvl_offset is not None:
            out.append(dvl(self.dvl_offset))
        if self.forecast_sigma is not None:
            out.append(forecast(self.forecast_sigma))
        return tuple(out)


#: The suites of the generalisation grid, by name (`edged sim VESSEL:SUITE`).
SUITES: dict[str, SuiteSpec] = {
    s.name: s
    for s in (
        SuiteSpec("reference", "DESIGN §9's rates without the draft marks: GNSS 10 Hz, compass 0.1° and "
                  "gyro 0.02 °/s at 10 Hz, IMU 50 Hz", gnss_period_s=0.1),
        SuiteSpec("coastal", "GNSS 1 Hz, compass 0.1° and gyro 0.02 °/s at 10 Hz, IMU 1 Hz", imu_hz=1.0),
        SuiteSpec("yacht", "A yacht's: GNSS 1 Hz (σ 2.5 m, 0.065 m/s), fluxgate 1° at 1 Hz, no rate gyro, "
                  "no IMU", position_sigma=2.5, velocity_sigma=0.065, heading_hz=1.0, heading_sigma_deg=1.0,
                  gyro_sigma_deg_s=None, imu_hz=None),
        SuiteSpec("mems", "GNSS 1 Hz, fluxgate 1° and MEMS gyro 0.1 °/s at 10 Hz, IMU 50 Hz",
                  heading_sigma_deg=1.0, gyro_sigma_deg_s=0.1),
        SuiteSpec("fog", "A large ship's: GNSS every 30 s, gyrocompass 0.05° and fibre-optic gyro 0.001 °/s at "
                  "10 Hz, IMU 1 Hz", gnss_period_s=30.0, position_sigma=2.5, velocity_sigma=0.065,
                  heading_sigma_deg=0.05, gyro_sigma_deg_s=0.001, imu_hz=1.0),
        SuiteSpec("fog-gnss1", "fog with GNSS at 1 Hz: gyrocompass 0.05° and fibre-optic gyro 0.001 °/s at 10 Hz, "
                  "IMU 1 Hz", heading_sigma_deg=0.05, gyro_sigma_deg_s=0.001, imu_hz=1.0),
        SuiteSpec("sparse", "GNSS every 30 s (σ 2.5 m, 0.065 m/s), compass 0.1° and gyro 0.02 °/s at 10 Hz, "
                  "IMU 1 Hz", gnss_period_s=30.0, position_sigma=2.5, velocity_sigma=0.065, imu_hz=1.0),
        SuiteSpec("two-compasses", "coastal plus a second compass 25° off (σ 0.5°, NMEA 2000 address 19)",
                  imu_hz=1.0, second_compass_deg=25.0),
    )
}
