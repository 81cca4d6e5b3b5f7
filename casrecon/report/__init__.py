"""Printing and tables of results, kept apart from the physics and the estimator."""
