"""The generic estimation engine: a sparse nonlinear least-squares problem with equality
constraints, min 1/2 |r(z)|^2 s.t. g(z) = 0, assembled from small block functions.

It knows nothing of IMUs, GPS or drops: measurement kinds (:mod:`casrecon.estimation.kinds`) hand
it :class:`~casrecon.estimation.engine.blocks.Term` objects (block functions with their global
columns and data), and it assembles the NLP (:mod:`.nlp`), solves it with Ipopt (:mod:`.solve`),
decides convergence (:mod:`.convergence`), and computes the covariance from the KKT matrix
(:mod:`.covariance`) and the checks on it (:mod:`.checks`).
"""
