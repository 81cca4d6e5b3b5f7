"""The TOML key reference (``casrecon.io.config_reference``, rendered as ``docs/problem-toml.md``)
is complete and current: every key the parsers read while loading the shipped problems (and the
optional ones they skip) is listed, every listed key is read by a parser, the page equals a fresh
rendering, and a file that omits every optional key loads to the listed defaults."""

from __future__ import annotations

import datetime as dt
import math
import tomllib
from pathlib import Path

import pytest

from casrecon.estimation.sixdof.joint import load_joint
from casrecon.io import config_reference as ref
from casrecon.io.kinematic_problem import load_kinematic
from casrecon.io.pointmass_problem import load_point_mass
from casrecon.io.problem import load_problem
from casrecon.io.problem_file import problem_kind
from casrecon.io.toml_fields import record_keys
from casrecon.io.vehicle_files import load_aero, load_vehicle

REPO = Path(__file__).resolve().parents[2]
PROBLEMS = REPO / "problems"
SHIPPED = sorted(p.parent for p in PROBLEMS.glob("*/problem.toml"))
FLYSIGHT_START = "2019-05-25T21:18:30Z"


def _listed(kind: ref.FileKind) -> set[tuple[str, str]]:
    return {(t.name, k.key) for t in kind.tables for k in t.keys}


def _load_recording(folder: Path) -> dict[str, set[tuple[str, str]]]:
    """Load one problem folder; the (table, key) pairs read, per file kind title."""
    kind = problem_kind(folder)
    with record_keys() as keys:
        if kind == "point-mass":
            load_point_mass(folder)
            files = {(folder / "problem.toml").resolve(): ref.POINT_MASS.title}
        elif kind == "kinematic":
            load_kinematic(folder)
            files = {(folder / "problem.toml").resolve(): ref.KINEMATIC.title}
        else:
            cfg = load_problem(folder)
            files = {cfg.path: ref.SIX_DOF.title, Path(cfg.sources["vehicle"]): ref.VEHICLE.title,
                     Path(cfg.sources["aero"]): ref.AERO.title}
    out: dict[str, set[tuple[str, str]]] = {}
    for path, table, key in keys:
        out.setdefault(files[path.resolve()], set()).add((table, key))
    return out


def _dump_toml(data: dict) -> str:
    """A minimal TOML writer for the tables of these tests (scalars, lists, nested tables)."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, (dt.datetime, int, float)):
            return v.isoformat() if isinstance(v, dt.datetime) else repr(v)
        return "[" + ", ".join(value(x) for x in v) + "]"

    lines: list[str] = []

    def table(prefix: str, d: dict) -> None:
        if prefix:
            lines.append(f"[{prefix}]")
        lines.extend(f"{k} = {value(v)}" for k, v in d.items() if not isinstance(v, dict))
        for k, v in d.items():
            if isinstance(v, dict):
                table(f"{prefix}.{k}" if prefix else k, v)

    table("", data)
    return "\n".join(lines) + "\n"


def _segment_problem(tmp_path: Path) -> Path:
    """A copy of a shipped point-mass problem that also gives the optional [segment] start/end."""
    src = PROBLEMS / "realdata-fs1-byron"
    data = tomllib.loads((src / "problem.toml").read_text())
    data["gps"]["file"] = str((src / data["gps"]["file"]).resolve())
    data["segment"] = {"start_utc": FLYSIGHT_START, "end_utc": "2019-05-25T21:19:30Z"}
    folder = tmp_path / "segment"
    folder.mkdir()
    (folder / "problem.toml").write_text(_dump_toml(data))
    return folder


@pytest.fixture(scope="module")
def keys_read(tmp_path_factory) -> dict[str, set[tuple[str, str]]]:
    """Every (table, key) the parsers read, per file kind, over the shipped problems, the joint
    file and a point-mass problem with the optional segment times."""
    read: dict[str, set[tuple[str, str]]] = {}
    for folder in SHIPPED + [_segment_problem(tmp_path_factory.mktemp("pm"))]:
        for title, pairs in _load_recording(folder).items():
            read.setdefault(title, set()).update(pairs)
    with record_keys() as keys:
        load_joint(PROBLEMS / "ees-joint.toml")
    read[ref.JOINT.title] = {(t, k) for _, t, k in keys}
    return read


def test_shipped_problems_cover_every_problem_kind():
    kinds = {problem_kind(f) for f in SHIPPED}
    assert kinds == {"six-dof", "point-mass", "kinematic"}


@pytest.mark.parametrize("kind", ref.FILE_KINDS, ids=("six-dof", "point-mass", "kinematic", "vehicle", "aero", "joint"))
def test_every_key_read_is_in_the_reference(kind, keys_read):
    tables = {t.name for t in kind.tables}
    # sub-tables are read as tables (not recorded); a key that names a listed table is one too
    leaves = {(t, k) for t, k in keys_read[kind.title] if (f"{t}.{k}" if t else k) not in tables}
    missing = sorted(leaves - _listed(kind))
    assert not missing, f"{kind.title}: keys read by the parser but not in the reference: {missing}"


@pytest.mark.parametrize("kind", ref.FILE_KINDS, ids=("six-dof", "point-mass", "kinematic", "vehicle", "aero", "joint"))
def test_every_listed_key_is_read_by_the_parser(kind, keys_read):
    stale = sorted(_listed(kind) - keys_read[kind.title])
    assert not stale, f"{kind.title}: keys in the reference that no parser reads: {stale}"


def test_docs_page_is_the_rendered_reference():
    page = REPO / "docs" / "problem-toml.md"
    assert page.read_text(encoding="utf-8") == ref.render_markdown(), (
        "docs/problem-toml.md is stale: run python -m casrecon.io.config_reference > docs/problem-toml.md")


def test_meanings_from_docstrings_exist():
    for kind in ref.FILE_KINDS:
        for table in kind.tables:
            for k in table.keys:
                assert k.resolved_meaning.strip(), (kind.title, table.name, k.key)
                if k.default is ref.FROM_FIELD:
                    assert k.resolved_default is not ref.REQUIRED  # raises without such a field or default


def _normal(v):
    if isinstance(v, (list, tuple)):
        return tuple(_normal(x) for x in v)
    if isinstance(v, float) and math.isnan(v):
        return "nan"
    return v


def _attr(obj, path: str):
    for part in path.split("."):
        obj = obj[part] if isinstance(obj, dict) else getattr(obj, part)
    return obj


def _check_defaults(kind: ref.FileKind, loaded, tables: tuple[str, ...] | None = None) -> int:
    checked = 0
    for table in kind.tables:
        if tables is not None and table.name not in tables:
            continue
        for k in table.keys:
            if k.attr is None or k.resolved_default is ref.REQUIRED:
                continue
            assert _normal(_attr(loaded, k.attr)) == _normal(k.resolved_default), (kind.title, table.name, k.key)
            checked += 1
    return checked


def _required_only(kind: ref.FileKind, data: dict, keep_tables: tuple[str, ...] = ()) -> dict:
    """``data`` with every key and table the reference lists as optional removed (except the tables
    in ``keep_tables``, kept, possibly empty)."""
    required = {(t.name, k.key) for t in kind.tables for k in t.keys if k.resolved_default is ref.REQUIRED}
    keep_tables = keep_tables + tuple(t.name for t in kind.tables if t.required)

    def strip(prefix: str, d: dict) -> dict:
        out = {}
        for key, v in d.items():
            name = f"{prefix}.{key}" if prefix else key
            if isinstance(v, dict):
                sub = strip(name, v)
                if name in keep_tables or any(n.startswith(name + ".") for n in keep_tables):
                    out[key] = sub
            elif (prefix, key) in required:
                out[key] = v
        return out

    return strip("", data)


def test_six_dof_problem_without_optional_keys_loads_to_listed_defaults(tmp_path):
    src = PROBLEMS / "ees-drop-1"
    data = tomllib.loads((src / "problem.toml").read_text())
    vehicle_src = (src / data["problem"]["vehicle"]).resolve()
    veh = _required_only(ref.VEHICLE, tomllib.loads(vehicle_src.read_text()))
    (tmp_path / "vehicle.toml").write_text(_dump_toml(veh))
    aero_src = PROBLEMS / "aero" / "davinci-zephyr.toml"      # analytic, with vanes
    aero = _required_only(ref.AERO, tomllib.loads(aero_src.read_text()), ("coefficients", "vanes"))
    aero.pop("table", None)                                 # required only with model = "table"
    (tmp_path / "aero.toml").write_text(_dump_toml(aero))
    data["problem"].update(vehicle="vehicle.toml", aero="aero.toml")
    data["atmosphere"]["sounding"] = str((src / data["atmosphere"]["sounding"]).resolve())
    data["sensors"]["baro"] = {}                             # an optional table present but empty
    minimal = _required_only(ref.SIX_DOF, data, ("truth", "sensors.baro"))
    assert "estimation" not in minimal and "dynamics" not in minimal and minimal["truth"] == {}
    (tmp_path / "problem.toml").write_text(_dump_toml(minimal))
    cfg = load_problem(tmp_path)
    assert _check_defaults(ref.SIX_DOF, cfg) >= 60
    assert _check_defaults(ref.VEHICLE, load_vehicle(tmp_path / "vehicle.toml")) == 2
    assert _check_defaults(ref.AERO, load_aero(tmp_path / "aero.toml")) >= 20
    assert cfg.estimation.disturbance is None and cfg.truth.disturbance is None


def test_point_mass_problem_without_optional_keys_loads_to_listed_defaults(tmp_path):
    src = PROBLEMS / "realdata-fs1-byron"
    data = tomllib.loads((src / "problem.toml").read_text())
    data["gps"]["file"] = str((src / data["gps"]["file"]).resolve())
    minimal = _required_only(ref.POINT_MASS, data)
    assert "drag" not in minimal and set(minimal["gps"]) == {"file"}
    (tmp_path / "problem.toml").write_text(_dump_toml(minimal))
    assert _check_defaults(ref.POINT_MASS, load_point_mass(tmp_path)) >= 15


def test_joint_file_without_optional_keys_loads_to_listed_defaults(tmp_path):
    folders = [str(PROBLEMS / n) for n in ("ees-drop-1", "ees-drop-2")]
    (tmp_path / "joint.toml").write_text(_dump_toml({"joint": {"name": "j", "drops": folders}}))
    cfg = load_joint(tmp_path / "joint.toml")
    assert cfg.shared is None            # listed as "every factor the drops estimate"
    assert (cfg.per_drop, cfg.fixed) == (ref.JOINT.table("joint").keys[3].resolved_default,
                                         ref.JOINT.table("joint").keys[4].resolved_default)
