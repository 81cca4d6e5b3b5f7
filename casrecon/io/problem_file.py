"""A problem's ``problem.toml``, read once per command, and the one place its kind is decided.

A command reads the file once (:func:`problem_document`) and hands the parsed
:class:`~casrecon.io.toml_fields.TomlDocument` to everything that needs it: the ``--out`` check
(:func:`casrecon.output.out_folder.input_paths`), :func:`problem_kind`, and the kind's loader
(:func:`casrecon.io.problem.load_problem`, :func:`casrecon.io.pointmass_problem.load_point_mass`,
:func:`casrecon.io.kinematic_problem.load_kinematic`), which all accept a path or the document.
"""

from __future__ import annotations

from pathlib import Path

from casrecon.io.toml_fields import TomlDocument, read_toml

#: The problem kinds of ``[problem] kind`` (default the first): a 6-DOF drop with an aero model, a
#: GPS-only point mass, an IMU-driven (kinematic) reconstruction.
KINDS = ("six-dof", "point-mass", "kinematic")


def problem_document(source: str | Path | TomlDocument) -> TomlDocument:
    """The parsed ``problem.toml`` of a problem folder or file (parsed now), or ``source`` itself
    when it is already a parsed document. Raises a located InputError for a missing or malformed file."""
    if isinstance(source, TomlDocument):
        return source
    path = Path(source)
    return read_toml(path / "problem.toml" if path.is_dir() else path)


def problem_kind(source: str | Path | TomlDocument) -> str:
    """One of :data:`KINDS` from ``[problem] kind`` (default ``"six-dof"``); a located InputError
    when the table is missing or the kind unknown."""
    head = problem_document(source).fields().table("problem", required=True)
    return head.string("kind", KINDS[0], choices=KINDS)


def problem_name(document: TomlDocument) -> str:
    """``[problem] name`` of a parsed problem file, for messages before it is loaded (its path when
    the name is missing or not a string: the loader then says what is wrong)."""
    head = document.data.get("problem")
    name = head.get("name") if isinstance(head, dict) else None
    return name if isinstance(name, str) else str(document.path)
