"""The fit: data preparation, collocation transcription, NLP assembly, Ipopt solve, covariance.

Rooms (who may import whom: ``tests/unit/test_architecture.py``):

- :mod:`.engine`: the generic NLP engine (assembly, Ipopt and Gauss-Newton solves, convergence,
  covariance);
- :mod:`.numerics`: generic numerics (band-arrow factorisation and selected inverse,
  Savitzky-Golay smoothing, the Laplace evidence of a fit's quadratic model);
- :mod:`.kinds`: the measurement kinds whose residual blocks make a fit's NLP;
- :mod:`.sixdof`: the 6-DOF per-drop and joint fit;
- :mod:`.kinematic`: the IMU-driven (kinematic) reconstruction;
- :mod:`.pointmass`: the GPS-only point-mass fit;
- :mod:`.error_models`: the atmosphere-profile error model and the error models' sizes from the data;
- :mod:`.validation`: the pre-solve input checks.
"""
