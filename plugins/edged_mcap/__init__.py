"""MCAP recording for edged (DESIGN §7).

The recorder output writes raw data, measurements, estimates and health into MCAP
files with one JSON-schema'd channel per topic; the same package reads those files
back for replay (`edged.logs`), for `edged score` and `edged plot` (`edged.recordings`,
whose commands are `edged_analysis`'s), and implements the `inspect`, `export` and
`recover` commands.
"""
