"""The manoeuvring-state estimator (seeds 002, 001, 004): u, v, r, heading, accelerations,
drift and a short-term prediction from GNSS, heading, rate of turn and accelerometers.

`ctra`/`cmm` are the two kinematic models, `ekf`/`ukf`/`enkf` the filters (one module
each, the equations in their docstrings) behind one interface (`filter`), `model` what
they share (angles, Runge–Kutta, measurement rows), `adaptive` the NIS-driven process
noise, sensor noise and gates, `process_noise` the Q they scale, `predict` the
predictor and `forecast` the prediction rows it makes; `core` is the estimator the
worker host drives (its inputs, starts and resets, output and health), `update` one
measurement through its filter, `start` how a filter starts, `sources`/`track`/
`faults`/`gnss_checks` what judges the sensors, `health` what it reports as wrong;
`plugin` is the entry point.
"""
