"""The pre-solve input checks: :mod:`.data_checks`, which every fit runs on its data before any NLP
is built, with :mod:`.consistency` (the inputs against each other: barometer and atmosphere, IMU
impact and GPS descent, the sounding's date and place), and :mod:`.precheck`, which runs them alone
on a problem folder.

Imports: :mod:`.data_checks` and :mod:`.consistency` import no other room of
:mod:`casrecon.estimation` (the fits import them); :mod:`.precheck` prepares each kind of problem's
data as its fit would, so it imports the 6-DOF data, the kinematic inputs and the point-mass data
preparation (the edges ``tests/unit/test_architecture.py`` lists).
"""
