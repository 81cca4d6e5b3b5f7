"""Generic numerics, free of any problem kind: the sparse factorisation of band-arrow normal
matrices (:mod:`.banded_factor`) and entries of their inverse (:mod:`.selected_inverse`),
Savitzky-Golay smoothing (:mod:`.savgol`), and the Laplace evidence of a fit's quadratic model as a
function of its error models' sizes, on the null-space covariance (:mod:`.split_evidence`) or on
the KKT matrix (:mod:`.kkt_evidence`).

Imports: within :mod:`casrecon.estimation`, only :mod:`~casrecon.estimation.engine` and this room;
never the measurement kinds nor a problem-kind room (``tests/unit/test_architecture.py``).
"""
