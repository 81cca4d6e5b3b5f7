"""Error models and their sizes from the data: the atmosphere-profile error of a 6-DOF fit
(:mod:`.profile`); type-II maximum likelihood of the profile's sigmas (:mod:`.profile_sigma`), of
the GPS error model's sizes (:mod:`.gps_error_sigma`; the point-mass fit's:
:mod:`.pointmass_gps_sigma`), and of both together (:mod:`.error_model_sigma`).

Imports: within :mod:`casrecon.estimation`, the engine, the numerics, the measurement kinds and this
room, and of the 6-DOF room only the edge ``tests/unit/test_architecture.py`` lists (the
transcription's selection matrices, for the profile's spline).
"""
