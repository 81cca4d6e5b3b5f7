"""Measurement kinds: one module per kind of data or prior that enters a drop's fit.

Each kind says which parameters (with priors) it adds, makes its residual blocks as
:class:`~casrecon.estimation.engine.blocks.Term` objects for the engine, and computes its
per-sample residuals at the solution for the diagnostics; see :mod:`.base` for the interface and
:data:`casrecon.estimation.sixdof.drop.MEASUREMENT_KINDS` for the kinds a drop's fit uses.
"""
