"""The manoeuvring-state estimator (seeds 002, 001, 004): u, v, r, heading, accelerations,
drift and a short-term prediction from GNSS, heading, rate of turn and accelerometers.

`ctra`/`cmm` are the two kinematic models, `ekf`/`ukf`/`enkf` the filters (one module
each, the equations in their docstrings), `model` what they share (angles, Runge–Kutta,
measurement rows), `adaptive` the NIS-driven process noise, sensor noise and gates,
`predict` the predictor, `core` the estimator the worker host drives, `plugin` the
entry point.
"""
