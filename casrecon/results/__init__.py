"""The public result objects: what ``casrecon.fit``, ``casrecon.fit_joint`` and ``casrecon.load_results``
return (:class:`~casrecon.results.drop_fit.DropFit`, :class:`~casrecon.results.joint_fit.JointFit`,
:class:`~casrecon.results.pointmass_fit.PointMassFit`, :class:`~casrecon.results.kinematic_fit.KinematicFit`,
their :class:`~casrecon.results.parameters.Parameters` records).

Each holds a fit's parameters, time histories, residuals and report, answers questions about them
(``sample``, ``params``, ``adequacy``), and saves itself as the results folder the command line
writes (through the writers of :mod:`casrecon.output`) or loads from one. They sit above the
writers and the reports, and below the pipelines (:mod:`casrecon.pipelines`) that make them.
"""
