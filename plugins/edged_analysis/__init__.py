"""Estimates against truth and the pictures an analyst wants: `edged score` and
`edged plot` (DESIGN §4).

A plugin of its own, apart from the recorder: it reads recordings through the core's
`edged.recordings` (whichever plugin reads the file's format) and imports no other
plugin. Scoring: `truth` (the truth table), `recording` and `columns` (a recording's
estimates and sensors as arrays), `figures` (errors and what they say), `baselines`
(the sensors and derived baselines an estimate is compared with), `scoring` (the rows),
`scoretable` (the printed table). Plotting: `plotdata` and `stwdata` (the series),
`panels` and `drawing` (matplotlib, the optional `plot` extra).
"""
