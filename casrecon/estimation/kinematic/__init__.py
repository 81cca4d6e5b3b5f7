"""The IMU-driven (kinematic) reconstruction of any rigid body: its inputs from a kinematic or a
6-DOF problem (:mod:`.inputs`), its data and options (:mod:`.data`), its residual blocks
(:mod:`.terms`), its solver (:mod:`.solve`), its covariance (:mod:`.covariance`) and the fit
(:mod:`.fit`).

Imports: within :mod:`casrecon.estimation`, the engine, the numerics, the measurement kinds and this
room, and of the 6-DOF room only the edges ``tests/unit/test_architecture.py`` lists (its parameter
specs, its measured data for inputs from a 6-DOF problem, its Hermite basis).
"""
