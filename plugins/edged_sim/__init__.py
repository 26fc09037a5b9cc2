"""edged_sim: a simulated vessel that writes the logs edged reads.

It integrates a 3-DOF manoeuvring model (surge, sway, yaw) under rudder and engine
orders, adds the sea (current, waves, squat), samples a realistic sensor suite and
writes what those sensors would have sent: an NMEA 0183 log with TAG-block time, a
candump log of NMEA 2000 PGNs and the reference DBC frames, the truth behind them and
a description of the run. The estimators are judged against that truth.

Nothing here imports edged's input plugins: the logs are written from the published
formats (DESIGN §3, §5) so that the inputs are tested against an independent writer.
"""

__all__ = ["__version__"]

__version__ = "0.1.0"
