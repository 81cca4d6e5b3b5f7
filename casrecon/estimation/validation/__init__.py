"""The pre-solve input checks: :mod:`.data_checks`, which every fit runs on its data before any NLP
is built, and :mod:`.precheck`, which runs them alone on a problem folder.

Imports: :mod:`.data_checks` imports no other room of :mod:`casrecon.estimation` (the fits import
it); :mod:`.precheck` prepares each kind of problem's data as its fit would, so it imports the
6-DOF data, the kinematic inputs and the point-mass data preparation (the edges
``tests/unit/test_architecture.py`` lists).
"""
