"""Draft at six marks (ESTIMATORS.md §3, seed 003).

One estimator plugin, `type = "draft"`, with two modes:

- `adaptive` (default, `waves.py`): per mark, the wave-free draft as a level with its
  rate and acceleration, and the wave-induced motion as a bank of stochastic resonators
  spanning the periods a ship meets (a spectrum, not one sine), so that each mark gives
  the filtered instantaneous draft and the mean under it;
- `paper` (`paper.py`): the paper's three-state filter per mark, eqs. (13)–(24), with
  the discretisation fix ESTIMATORS.md §3 describes, ω_e and ε from configuration.

From the six marks (`derived.py`): mean draft, trim, list, heel, hog/sag deflection,
Barrass squat from the STW estimate, under-keel clearance from a depth sounder, and the
displacement change and cargo rate from a TPC or a hydrostatic table. A mark that fails
(`marks.py`) is left out of them and filled from its partner and the list seen at the
other stations.
"""
