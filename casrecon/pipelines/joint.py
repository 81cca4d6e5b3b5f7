"""The multi-drop joint aero fit pipeline: joint file or problem list -> each drop's problem read once
-> joint fit (with the single-drop fits of the sigma comparison beside it) -> products -> JointFit."""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from casrecon.io.errors import InputError
from casrecon.io.problem_file import problem_document
from casrecon.io.toml_fields import TomlDocument, read_toml
from casrecon.pipelines.options import DEFAULT_OPTIONS, FitOptions
from casrecon.progress import stage
from casrecon.results.joint_fit import JointFit

if TYPE_CHECKING:
    from casrecon.estimation.sixdof.joint import JointConfig

LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class JointProblem:
    """What a joint fit reads, each file parsed once.

    Attributes
    ----------
    config : casrecon.estimation.sixdof.joint.JointConfig
        Name, drops (problem folders), shared, per-drop and fixed factors.
    documents : tuple of TomlDocument
        The joint file's document (when there is one) and every drop's ``problem.toml``; the
        ``--out`` check reads its inputs from these (:func:`casrecon.output.out_folder.input_paths`).
    drops : tuple of TomlDocument
        Each drop's ``problem.toml``, in the order of ``config.drops``.
    """

    config: JointConfig
    documents: tuple[TomlDocument, ...]
    drops: tuple[TomlDocument, ...]


def joint_problem(problems: str | Path | Sequence[str | Path], *, name: str = "joint",
                  shared: Sequence[str] | None = None, per_drop: Sequence[str] = (),
                  fixed: Sequence[str] = ()) -> JointProblem:
    """Read a joint fit's inputs: one joint ``.toml`` file (``[joint] name, drops, shared, per_drop,
    fixed``; the keywords are then ignored), or at least two problem folders with the keywords.

    Raises
    ------
    InputError
        A missing or malformed file, a single problem that is not a joint file, or fewer than two drops.
    """
    from casrecon.estimation.sixdof.joint import JointConfig, load_joint

    listed = [problems] if isinstance(problems, (str, Path)) else list(problems)
    head: tuple[TomlDocument, ...] = ()
    if len(listed) == 1 and Path(listed[0]).is_file() and str(listed[0]).endswith(".toml"):
        joint_file = read_toml(listed[0])
        config = load_joint(joint_file)
        head = (joint_file,)
    elif len(listed) < 2:
        where = ", ".join(map(str, listed)) or "(none)"
        missing = "" if listed and Path(listed[0]).exists() else "file not found; "
        raise InputError(where, f"{missing}joint needs at least two problems, or one joint .toml file")
    else:
        config = JointConfig(name=name, drops=tuple(Path(p) for p in listed),
                             shared=tuple(shared) if shared is not None else None, per_drop=tuple(per_drop),
                             fixed=tuple(fixed))
    drops = tuple(problem_document(p) for p in config.drops)
    return JointProblem(config, head + drops, drops)


def fit_joint_problems(problem: JointProblem, options: FitOptions = DEFAULT_OPTIONS, *, single: bool = True
                       ) -> JointFit:
    """Joint aero fit of several drops in one NLP, with each drop's residuals and reconciled simulations.

    Parameters
    ----------
    problem : JointProblem
        From :func:`joint_problem`.
    options : FitOptions
        Solver overrides for every drop (``kinematic_check`` does not apply); ``concurrent`` also
        computes the drops' products on a second core.
    single : bool
        Also fit each drop alone, on two processes beside the joint fit, for the joint-vs-single sigma
        table (stopped at once if the joint fit fails).

    Raises
    ------
    InputError, FitError
    """
    from concurrent.futures import ThreadPoolExecutor

    from casrecon.analysis.fit_products import fit_products
    from casrecon.analysis.single_sigmas import single_drop_sigmas
    from casrecon.estimation.sixdof.joint import fit_joint
    from casrecon.io.problem import load_problem
    from casrecon.parallel import stop_child_processes
    from casrecon.scenario import Scenario

    if options.kinematic_check:
        raise InputError(problem.documents[0].path, "kinematic_check applies to single-drop 6-DOF fits only")
    t0 = time.perf_counter()
    configs = [load_problem(d) for d in problem.drops]
    scenarios = [Scenario.from_config(c) for c in configs]
    # the single-drop fits of the sigma comparison run on two processes beside the joint fit (a thread
    # of this process waits for them), on the cores the joint fit leaves idle
    background = ThreadPoolExecutor(1) if single else None
    singles = None if background is None else background.submit(single_drop_sigmas, configs)
    try:
        result = fit_joint(scenarios, problem.config, **options.solver_overrides)
    except BaseException:
        stop_child_processes()  # the single-drop fits are not wanted now: the run ends without them
        raise
    finally:
        if background is not None:
            background.shutdown(wait=False)
    if singles is None:
        sigmas = {}
    else:
        with stage(LOG, f"waiting for the single-drop fits of the sigma comparison ({len(configs)} drops)"):
            sigmas = singles.result()
    products = {}
    for k, d in enumerate(result.drops):
        with stage(LOG, f"drop {k + 1} of {len(result.drops)} ({d.scenario.config.name}): residuals, reconciled "
                        "simulations, aerodynamic coefficients and model adequacy"):
            products[d.scenario.config.name] = fit_products(d, concurrent=options.concurrent)
    result.timings["total_s"] = time.perf_counter() - t0
    return JointFit.from_fit(result, products, sigmas)
