"""Measurement kinds: one module per kind of data or prior that enters a drop's fit.

Each kind says which parameters (with priors) it adds, makes its residual blocks as
:class:`~casrecon.estimation.engine.blocks.Term` objects for the engine, and computes its
per-sample residuals at the solution for the diagnostics; see :mod:`.base` for the interface and
:data:`casrecon.estimation.sixdof.drop.MEASUREMENT_KINDS` for the kinds a drop's fit uses.

A *sample kind* (:mod:`.samples`: timed samples that a function of the body's state predicts, and
its own parameters) is written once for both the 6-DOF fit (wrapped by :mod:`.sample_terms`) and
the kinematic fit (:mod:`casrecon.estimation.kinematic.samples`).

Imports: within :mod:`casrecon.estimation`, the engine, the numerics and this room, and of the
6-DOF room only what the kinds are built on (its data, layout, parameters, transcription, and for
the IMU kind's sub-grid covariance its sub-grid model and initial guess): the edges
``tests/unit/test_architecture.py`` lists. The kinematic and point-mass fits use the drag,
disturbance and prior kinds.
"""
