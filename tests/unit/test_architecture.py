"""Architecture of the casrecon package, checked on its source with ``ast`` (nothing is imported).

Layers, lowest first; a module may import casrecon modules of its own layer or lower ones only:

0. ``casrecon.physics`` (pure CasADi, SI) and ``casrecon.parallel``;
1. ``casrecon.io`` (readers, configuration) and ``casrecon.scenario``;
2. ``casrecon.simulation`` (forward simulation, synthetic data);
3. ``casrecon.estimation`` (the NLP engine);
4. ``casrecon.analysis``;
5. ``casrecon.output`` (writers) and ``casrecon.report`` (text, tables, figures);
6. ``casrecon.results`` (the public result objects: they save through the writers, report through the reports);
7. ``casrecon.pipelines`` (one pipeline per problem kind: load, fit, products, report, result);
8. ``casrecon.cli``, ``casrecon.cli_guard``, ``casrecon.cli_options``, ``casrecon.cli_montecarlo``,
   ``casrecon.__main__`` and the public API in ``casrecon/__init__.py``.

Also: no private name (leading underscore) is imported from, or used as an attribute of, another
casrecon module (a private module may be imported inside its own package), and no module is longer
than :data:`MAX_LINES` lines.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "casrecon"
MAX_LINES = 500
LAYERS = {"physics": 0, "parallel": 0, "io": 1, "scenario": 1, "simulation": 2, "estimation": 3, "analysis": 4,
          "output": 5, "report": 5, "results": 6, "pipelines": 7, "cli": 8, "cli_guard": 8, "cli_options": 8,
          "cli_montecarlo": 8, "__main__": 8, "__init__": 8}


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
