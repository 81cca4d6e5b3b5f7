"""The GPS-only point-mass (3-DOF) fit: which fixes it uses and the descent segment
(:mod:`.segment`), the fit (:mod:`.fit`) and the Kalman-filter innovations of a fit with an area
process (:mod:`.innovations`).

Imports: within :mod:`casrecon.estimation`, the engine, the numerics, the measurement kinds and this
room, and of the other rooms only the edges ``tests/unit/test_architecture.py`` lists (the 6-DOF
mesh, layout and parameter specs, the error models' sizes, the pre-solve data checks).
"""
