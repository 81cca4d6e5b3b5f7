"""Analyses built on the estimator: observability, Monte Carlo, estimator consistency, fit products."""
