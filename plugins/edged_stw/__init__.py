"""Speed through water without trusting the Doppler log (ESTIMATORS.md §1, seed 000).

One estimator plugin, `type = "stw"`, with two modes:

- `vector` (default, `vector.py`): the vessel's ground motion from GNSS and the IMU
  (`ground.py`), the sea current as a two-dimensional vector from forecasts and from
  the difference between heading and course (`current.py`), STW = ground velocity −
  current, with along-ship and athwartship parts;
- `paper` (`paper.py`): the paper's four-state filter, eqs. (12)–(25), kept so that
  our results can be set beside the paper's.

Either way the Doppler/EM log is never an input: its error against the estimate (offset
and scale, `dvl.py`) is the by-product the crew did not have.
"""
