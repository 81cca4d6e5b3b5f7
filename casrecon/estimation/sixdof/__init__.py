"""The 6-DOF fit of one drop and the joint fit of several: the measured data (:mod:`.fitdata`),
the collocation mesh and transcription (:mod:`.transcription`, :mod:`.subgrid`), where the
unknowns sit (:mod:`.layout`, :mod:`.parameters`), a drop's NLP (:mod:`.drop`), the initial guess
(:mod:`.initial_guess`), the solver settings (:mod:`.settings`), the clock-offset continuation
(:mod:`.continuation`), the per-drop and joint fits (:mod:`.fit`, :mod:`.joint`), the bands
(:mod:`.bands`) and what a fit leaves for plots and checks (:mod:`.diagnostics`).

Imports: within :mod:`casrecon.estimation`, the engine, the numerics, the measurement kinds and this
room, and of the other rooms only the edges ``tests/unit/test_architecture.py`` lists (the
atmosphere-profile model and the error models' sizes, the pre-solve data checks). The measurement
kinds and the kinematic and point-mass fits in turn build on its data, transcription, layout and
parameters.
"""
