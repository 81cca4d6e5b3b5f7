"""Architecture of the casrecon package, checked on its source with ``ast`` (nothing is imported).

Layers, lowest first; a module may import casrecon modules of its own layer or lower ones only:

0. ``casrecon.physics`` (pure CasADi, SI), ``casrecon.parallel`` and ``casrecon.progress``;
1. ``casrecon.io`` (readers, configuration) and ``casrecon.scenario``;
2. ``casrecon.simulation`` (forward simulation, synthetic data);
3. ``casrecon.estimation`` (the NLP engine);
4. ``casrecon.analysis``;
5. ``casrecon.output`` (writers) and ``casrecon.report`` (text, tables, figures);
6. ``casrecon.results`` (the public result objects: they save through the writers, report through the reports);
7. ``casrecon.pipelines`` (one pipeline per problem kind: load, fit, products, report, result);
8. ``casrecon.cli``, ``casrecon.cli_guard``, ``casrecon.cli_options``, ``casrecon.cli_montecarlo``,
   ``casrecon.__main__`` and the public API in ``casrecon/__init__.py``.

Inside ``casrecon.estimation``, every module lies in a room (:data:`ESTIMATION_ROOMS`): the generic
rooms ``engine`` (the NLP engine) and ``numerics`` import no other room; ``kinds`` (the measurement
kinds) imports the generic rooms only, and the problem-kind rooms (``sixdof``, ``kinematic``,
``pointmass``, ``error_models``, ``validation``) import the generic rooms and ``kinds``; any other
import across rooms is one of :data:`ALLOWED_CROSS_ROOM`, each measured and with its reason.

No casrecon module is in an import cycle (module-level and function-level imports alike).

Also: no private name (leading underscore) is imported from, or used as an attribute of, another
casrecon module (a private module may be imported inside its own package), and no module is longer
than :data:`MAX_LINES` lines.
"""

from __future__ import annotations

import ast
import functools
from dataclasses import dataclass
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "casrecon"
MAX_LINES = 500
LAYERS = {"physics": 0, "parallel": 0, "progress": 0, "io": 1, "scenario": 1, "simulation": 2, "estimation": 3,
          "analysis": 4, "output": 5, "report": 5, "results": 6, "pipelines": 7, "cli": 8, "cli_guard": 8,
          "cli_options": 8, "cli_montecarlo": 8, "__main__": 8, "__init__": 8}

ESTIMATION = "casrecon.estimation"
#: Rooms that know no problem kind: the NLP engine and the generic numerics.
GENERIC_ROOMS = frozenset({"engine", "numerics"})
#: The measurement kinds (residual blocks and parameters of a fit's NLP).
KINDS_ROOM = "kinds"
#: Rooms of one kind of problem or of its error models and input checks.
PROBLEM_ROOMS = frozenset({"sixdof", "kinematic", "pointmass", "error_models", "validation"})
ESTIMATION_ROOMS = GENERIC_ROOMS | {KINDS_ROOM} | PROBLEM_ROOMS

#: The imports across rooms beyond the rules, each measured: (importing room, or one module of it,
#: relative to ``casrecon.estimation``; imported module). Keep it to what the code needs: an entry
#: nothing uses any more fails :func:`test_every_allowed_cross_room_import_is_used`.
ALLOWED_CROSS_ROOM = frozenset({
    # The measurement kinds are the 6-DOF fit's: a kind's parameters and blocks are made from one
    # drop's measured data (FitData), read the drop's unknowns through its layout (DropLayout,
    # BlockLocals), declare its parameters (ParameterSpec; the priors read the ParameterSet) and are
    # the collocation transcription's blocks (interval functions, Hermite basis, selection matrices;
    # the drag kind's selection matrix serves the point-mass fit).
    ("kinds", "sixdof.fitdata"),
    ("kinds", "sixdof.layout"),
    ("kinds", "sixdof.parameters"),
    ("kinds", "sixdof.transcription"),
    # With disturbance states the IMU kind whitens each interval's samples by the sub-grid
    # covariance (SubgridModel), linearised on the initial guess's trajectory.
    ("kinds", "sixdof.subgrid"),
    ("kinds", "sixdof.initial_guess"),
    # A kinematic fit from a 6-DOF problem reads its data with the 6-DOF loader (the same files,
    # windows and data rules, so the two fits compare); its IMU, clock and barometer parameters are
    # ParameterSpecs; its interval blocks use the collocation's Hermite basis.
    ("kinematic", "sixdof.fitdata"),
    # ... and checks the barometer and the sounding with the pre-solve consistency checks
    ("kinematic", "validation.consistency"),
    ("kinematic", "sixdof.parameters"),
    ("kinematic", "sixdof.transcription"),
    # The point-mass fit reuses the 6-DOF mesh (Mesh), layout (DropLayout) and parameters
    # (ParameterSet, ParameterSpec), estimates its GPS error model's sizes from the data with the
    # refit limit of the profile sigmas (MAX_REFITS), and runs the pre-solve data check (the
    # segment rule uses its GPS_MAX_GAP_S).
    ("pointmass", "sixdof.transcription"),
    ("pointmass", "sixdof.layout"),
    ("pointmass", "sixdof.parameters"),
    ("pointmass", "error_models.pointmass_gps_sigma"),
    ("pointmass", "error_models.profile_sigma"),
    ("pointmass", "validation.data_checks"),
    # The atmosphere-profile correction enters the model's parameter vector through the
    # transcription's selection matrix.
    ("error_models", "sixdof.transcription"),
    # The profile unknowns are part of a drop's layout and NLP (ProfileGrid); the 6-DOF fit
    # estimates the profile and GPS error sizes from its own solution and refits with them; its
    # data loader runs the pre-solve data check.
    ("sixdof", "error_models.profile"),
    ("sixdof", "error_models.profile_sigma"),
    ("sixdof", "error_models.error_model_sigma"),
    # ... and refuses to refit with sizes beyond the plausibility limits (a gross input error).
    ("sixdof", "error_models.plausibility"),
    # ... and carries the sizes' own uncertainty into the covariance of the fit that stands.
    ("sixdof", "error_models.size_uncertainty"),
    ("sixdof", "validation.data_checks"),
    # precheck (not data_checks) prepares each kind of problem's data as its fit would.
    ("validation.precheck", "sixdof.fitdata"),
    ("validation.precheck", "kinematic.inputs"),
    ("validation.precheck", "pointmass.fit"),
})

@dataclass(frozen=True)
class Module:
    name: str  # dotted, e.g. casrecon.io.flysight
    path: Path
    is_package: bool

    @property
    def package(self) -> str:
        """The package that relative imports start from."""
        return self.name if self.is_package else self.name.rpartition(".")[0]

    def tree(self) -> ast.Module:
        return ast.parse(self.path.read_text(), filename=str(self.path))


def modules() -> list[Module]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        is_package = parts[-1] == "__init__"
        out.append(Module(".".join(parts[:-1] if is_package else parts), path, is_package))
    return out


MODULES = {m.name: m for m in modules()}


def layer(name: str) -> int:
    """Layer of a dotted casrecon module name (the package ``casrecon`` itself is the public API)."""
    parts = name.split(".")
    return LAYERS["__init__"] if len(parts) == 1 else LAYERS[parts[1]]


def is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def absolute(module: Module, node: ast.ImportFrom) -> str:
    """The absolute module name of a ``from X import ...`` statement."""
    if not node.level:
        return node.module or ""
    base = module.package.split(".")
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


@functools.cache
def casrecon_imports(module: Module) -> list[tuple[int, str, str | None]]:
    """``(line, imported module, imported name or None)`` of every casrecon import, also inside functions.

    For ``from casrecon.a import b`` where ``b`` is a module, the imported module is ``casrecon.a.b``.
    """
    found = []
    for node in ast.walk(module.tree()):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name, None) for a in node.names if a.name.split(".")[0] == "casrecon"]
        elif isinstance(node, ast.ImportFrom):
            source = absolute(module, node)
            if source.split(".")[0] != "casrecon":
                continue
            for a in node.names:
                sub = f"{source}.{a.name}"
                found.append((node.lineno, sub, None) if sub in MODULES else (node.lineno, source, a.name))
    return found


def module_bindings(module: Module, tree: ast.Module) -> dict[str, str]:
    """Local names bound to casrecon modules by imports (``import casrecon.a.b as m``, ``from casrecon.a import b``)."""
    names = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "casrecon" and a.asname:
                    names[a.asname] = a.name
        elif isinstance(node, ast.ImportFrom):
            for a in node.names:
                sub = f"{absolute(module, node)}.{a.name}"
                if sub in MODULES:
                    names[a.asname or a.name] = sub
    return names


def dotted(node: ast.expr) -> str | None:
    """``a.b.c`` of an attribute chain on a name, else None."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        return ".".join([node.id, *reversed(parts)])
    return None


def test_every_module_has_a_layer():
    unknown = [name for name in MODULES if name != "casrecon" and name.split(".")[1] not in LAYERS]
    assert not unknown, f"modules outside the known layers (add them to LAYERS): {unknown}"


def test_imports_only_go_down_the_layers():
    violations = []
    for module in MODULES.values():
        own = layer(module.name)
        for line, target, _ in casrecon_imports(module):
            if layer(target) > own:
                violations.append(f"{module.path.relative_to(PACKAGE.parent)}:{line}: {module.name} (layer {own}) "
                                  f"imports {target} (layer {layer(target)})")
    assert not violations, "upward imports:\n" + "\n".join(violations)


def test_no_private_name_is_used_across_modules():
    violations = []
    for module in MODULES.values():
        where = module.path.relative_to(PACKAGE.parent)
        for line, target, name in casrecon_imports(module):
            if target == module.name:
                continue
            private_parts = [i for i, p in enumerate(target.split(".")) if is_private(p)]
            # a private module may be imported inside the package that holds it
            if private_parts and not module.name.startswith(".".join(target.split(".")[:private_parts[0]]) + "."):
                violations.append(f"{where}:{line}: imports the private module {target}")
            if name is not None and is_private(name):
                violations.append(f"{where}:{line}: imports {name} from {target}")
        tree = module.tree()
        bound = module_bindings(module, tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and is_private(node.attr):
                chain = dotted(node.value)
                target = bound.get(chain) if chain in bound else chain
                if target in MODULES and target != module.name:
                    violations.append(f"{where}:{node.lineno}: uses {target}.{node.attr}")
    assert not violations, "private names used across modules:\n" + "\n".join(violations)


def test_no_module_is_too_long():
    long = {str(m.path.relative_to(PACKAGE.parent)): n for m in MODULES.values()
            if (n := len(m.path.read_text().splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines: {long}"


def room(name: str) -> str | None:
    """The room of a ``casrecon.estimation`` module (its subpackage), '' for the package itself, None
    outside it."""
    if name != ESTIMATION and not name.startswith(ESTIMATION + "."):
        return None
    parts = name.split(".")
    return parts[2] if len(parts) > 2 else ""


def cross_room_allowed(importer: str, target: str) -> bool:
    """Whether ``importer`` may import ``target`` (both in casrecon.estimation, other rooms)."""
    source, dest = room(importer), room(target)
    if dest in GENERIC_ROOMS or dest == "":
        return True
    if source in GENERIC_ROOMS:
        return False
    if dest == KINDS_ROOM and source in PROBLEM_ROOMS:
        return True
    rel, rel_target = importer[len(ESTIMATION) + 1:], target[len(ESTIMATION) + 1:]
    return any((who == source or rel == who or rel.startswith(who + ".")) and rel_target == what
               for who, what in ALLOWED_CROSS_ROOM)


def cross_room_imports() -> list[tuple[Module, int, str]]:
    """``(module, line, imported module)`` of every import from one estimation room into another."""
    found = []
    for module in MODULES.values():
        source = room(module.name)
        if not source:
            continue
        for line, target, _ in casrecon_imports(module):
            dest = room(target)
            if dest is not None and dest != source:
                found.append((module, line, target))
    return found


def test_every_estimation_module_is_in_a_room():
    outside = [name for name in MODULES if room(name) not in (None, "") and room(name) not in ESTIMATION_ROOMS]
    flat = [name for name in MODULES if room(name) == "" and name != ESTIMATION]
    assert not outside and not flat, (f"casrecon.estimation modules outside the rooms {sorted(ESTIMATION_ROOMS)} "
                                      f"(put each in its room, or add a room): {sorted(outside + flat)}")


def test_imports_across_estimation_rooms_follow_the_rules():
    violations = [f"{module.path.relative_to(PACKAGE.parent)}:{line}: {module.name} ({room(module.name)}) imports "
                  f"{target} ({room(target)})"
                  for module, line, target in cross_room_imports() if not cross_room_allowed(module.name, target)]
    assert not violations, ("imports across casrecon.estimation rooms that the rules do not allow (see the module "
                            "docstring; a needed one goes in ALLOWED_CROSS_ROOM with its reason):\n"
                            + "\n".join(violations))


def test_every_allowed_cross_room_import_is_used():
    used = set()
    for module, _, target in cross_room_imports():
        rel, rel_target = module.name[len(ESTIMATION) + 1:], target[len(ESTIMATION) + 1:]
        used |= {(who, what) for who, what in ALLOWED_CROSS_ROOM
                 if (who == room(module.name) or rel == who or rel.startswith(who + ".")) and what == rel_target}
    unused = sorted(ALLOWED_CROSS_ROOM - used)
    assert not unused, f"ALLOWED_CROSS_ROOM entries no module needs any more (remove them): {unused}"


def import_graph() -> dict[str, set[str]]:
    """casrecon module -> the casrecon modules it imports (module and function level; a name imported
    from a package counts as an import of the package)."""
    graph = {name: set() for name in MODULES}
    for module in MODULES.values():
        for _, target, _ in casrecon_imports(module):
            if target != module.name and target in MODULES:
                graph[module.name].add(target)
    return graph


def import_cycles(graph: dict[str, set[str]]) -> list[frozenset[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = set()
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.add(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        cycles.append(frozenset(component))
    return cycles


def cycle_path(graph: dict[str, set[str]], component: frozenset[str]) -> str:
    """One cycle through a component, for the message: a -> b -> ... -> a."""
    start = min(component)
    path, seen = [start], {start}
    while True:
        following = sorted(n for n in graph[path[-1]] if n in component)
        if start in following and len(path) > 1:
            return " -> ".join(path + [start])
        nxt = next((n for n in following if n not in seen), None)
        if nxt is None:
            return " -> ".join(path + [following[0]])
        path.append(nxt)
        seen.add(nxt)


def test_no_import_cycles():
    graph = import_graph()
    new = list(import_cycles(graph))
    assert not new, "casrecon modules in an import cycle:\n" + "\n".join(cycle_path(graph, c) for c in new)
