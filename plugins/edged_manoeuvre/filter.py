"""The one interface the manoeuvre core drives a filter through.

The core never asks which filter it runs: the EKF (`ekf.py`), the UKF (`ukf.py`) and
the EnKF (`enkf.py`) each declare `KalmanFilter` and give it
- `x` (the state of the model, `ctra`/`cmm`) and `P` (its covariance): an ensemble's
  are its members' mean and sample covariance, computed when read, so that an
  addition made in place to an EnKF's `P` changes nothing;
- `predict(dt, Qc)`: x, P carried `dt` seconds on by f (F), with the continuous-time
  process noise density Qc (Q = Qc·Δt);
- `update(kind, z, R, gate)`: one sensor's rows of h (H) with its noise R, applied
  unless the NIS exceeds `gate` (the `Innovation` says which, and its NIS and rcond);
- `shift(dn, de)` (the plane's origin moved) and `reset_position(z, R)` (a GNSS jump);
- `ensemble_size()`: the members of an ensemble, 0 for a filter of one state.
The configured one is made at a start (`start.make_filter`).
"""

from __future__ import annotations

from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from .model import Innovation


@runtime_checkable
class KalmanFilter(Protocol):
    """What the core calls on a filter (see the module's docstring)."""

    #: The configuration's name of the filter (`filter = "ekf"`).
    name: ClassVar[str]
    #: The state x and its covariance P, in the model's order.
    x: np.ndarray
    P: np.ndarray

    def predict(self, dt: float, Qc: np.ndarray) -> None:
        """x, P carried dt seconds on (nothing for dt ≤ 0), Q = Qc·dt."""
        ...

    def update(self, kind: str, z: np.ndarray, R: np.ndarray, gate: float | None = None) -> Innovation:
        """One sensor's measurement z (its rows of h, noise R); kept out beyond `gate`."""
        ...

    def shift(self, dn: float, de: float) -> None:
        """The plane's origin moved by (dn, de) m: positions follow, nothing else."""
        ...

    def reset_position(self, z: np.ndarray, R: np.ndarray) -> None:
        """Position from a fix alone (a GNSS jump): its covariance R."""
        ...

    def ensemble_size(self) -> int:
        """The ensemble's members (0: not an ensemble)."""
        ...

