"""Pure CasADi physics in SI units: rotations, gravity, atmosphere, aero, vehicle, dynamics, sensors.

Every function here builds CasADi expressions (SX or MX) from symbolic or numeric inputs, so the
simulator and the estimator share one model.
"""
