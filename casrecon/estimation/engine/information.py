"""Which curvature a fit's covariance inverts (:func:`.covariance.compute_covariance`): the names
and their report text. Kept apart from the covariance so that reports read it without CasADi."""

from __future__ import annotations

#: Curvatures the covariance can invert: "observed", the exact Hessian of the Lagrangian at the
#: solution; "expected", the Gauss-Newton J^T J.
INFORMATION = ("observed", "expected")


def information_text(information: str) -> str:
    """What a covariance's ``information`` ("observed", "expected" or "expected (reason)") means,
    for reports: the matrix inverted in the KKT matrix, and the reason for a fallback."""
    kind, _, reason = information.partition(" (")
    text = {"observed": "observed information (exact Hessian of the Lagrangian at the solution)",
            "expected": "expected information (Gauss-Newton J^T J, the Fisher information)"}[kind]
    return f"{text}; {reason.rstrip(')')}" if reason else text
