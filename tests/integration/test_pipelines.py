"""One pipeline per problem kind: ``casrecon.fit`` / ``casrecon.fit_joint`` and the command line write the
same results folder (byte for byte but for timings), every option of ``casrecon fit`` and ``casrecon
joint`` exists in the API, and a command reads each ``problem.toml`` once."""

from __future__ import annotations

import inspect
import tomllib
from pathlib import Path

import pytest
from conftest import script_module

import casrecon
from casrecon.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[2]
PROBLEMS = ROOT / "problems"

results_identity = script_module(ROOT / "problems" / "tools" / "results_identity.py")


def differing_files(api: Path, cli: Path) -> list[str]:
    """Results files of two folders (both written from this tree) that differ other than in timings,
    or that only one has (:func:`results_identity.verdicts`)."""
    found = results_identity.verdicts(api, cli, ([str(api)], [str(cli)]))
    return [f"{rel} ({verdict})" for rel, verdict in found.items() if verdict in ("different", "missing")]


@pytest.mark.parametrize("problem, options, flags", [
    ("ees-drop-2", {}, []),
    ("ees-drop-2", {"kinematic_check": True, "solver": "auto"}, ["--kinematic-check", "--solver", "auto"]),
    ("realdata-skyderby-411", {}, []),
    ("realdata-fs2-chicago-kinematic", {}, []),
])
def test_the_api_and_the_command_line_write_the_same_folder(problem, options, flags, tmp_path):
    api = casrecon.fit(PROBLEMS / problem, **options).save(tmp_path / "api")
    assert main(["fit", str(PROBLEMS / problem), "--out", str(tmp_path / "cli"), "--no-figures", "--quiet",
                 *flags]) == 0
    assert sorted(p.name for p in api.iterdir()) == sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert differing_files(api, tmp_path / "cli") == []
    if options.get("kinematic_check"):
        assert (api / "kinematic_check.json").is_file() and "kinematic check" in (api / "report.txt").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("problem", sorted(p.parent.name for p in PROBLEMS.glob("*/problem.toml")))
def test_every_shipped_problem_writes_the_same_folder_through_the_api_and_the_command_line(problem, tmp_path):
    """Every shipped problem (the default suite does one of each kind above): about 5 minutes in all."""
    api = casrecon.fit(PROBLEMS / problem).save(tmp_path / "api")
    assert main(["fit", str(PROBLEMS / problem), "--out", str(tmp_path / "cli"), "--no-figures", "--quiet"]) == 0
    assert differing_files(api, tmp_path / "cli") == []


@pytest.mark.slow
def test_the_shipped_joint_file_writes_the_same_folder_through_the_api_and_the_command_line(tmp_path):
    joint = PROBLEMS / "ees-joint.toml"
    api = casrecon.fit_joint(joint).save(tmp_path / "api")
    assert main(["joint", str(joint), "--out", str(tmp_path / "cli"), "--no-figures", "--quiet"]) == 0
    assert differing_files(api, tmp_path / "cli") == []


def test_the_joint_api_and_the_command_line_write_the_same_folder(tmp_path):
    drops = [str(PROBLEMS / "ees-drop-1"), str(PROBLEMS / "ees-drop-2")]
    api = casrecon.fit_joint(drops, name="pair", single=False, solver="auto").save(tmp_path / "api")
    assert main(["joint", *drops, "--name", "pair", "--no-single", "--solver", "auto", "--out",
                 str(tmp_path / "cli"), "--no-figures", "--quiet"]) == 0
    assert (api / "drops").is_dir()
    assert differing_files(api, tmp_path / "cli") == []


#: Options of the command line that say where and how results are written or printed, not what is computed.
OUTPUT_ONLY = {"help", "out", "force", "no_figures", "formats", "quiet", "verbose", "debug", "problem", "problems"}
#: Command-line options whose API keyword has another name.
API_NAME = {"no_single": "single"}


@pytest.mark.parametrize("command, function", [("fit", casrecon.fit), ("joint", casrecon.fit_joint)])
def test_every_command_line_option_exists_in_the_api(command, function):
    sub = next(a for a in build_parser()._actions if a.dest == "command").choices[command]
    options = {API_NAME.get(a.dest, a.dest) for a in sub._actions} - OUTPUT_ONLY
    keywords = set(inspect.signature(function).parameters)
    assert options <= keywords, f"casrecon {command} options missing from the API: {sorted(options - keywords)}"
    assert "print_level" in keywords  # --verbose


@pytest.fixture
def parsed_files(monkeypatch):
    """Every file ``tomllib.load`` parses in this process, in order."""
    seen: list[Path] = []
    real = tomllib.load

    def counting(fh, **kw):
        seen.append(Path(fh.name).resolve())
        return real(fh, **kw)

    monkeypatch.setattr(tomllib, "load", counting)
    return seen


@pytest.mark.parametrize("argv", [
    ["fit", "{P}/ees-drop-2"],
    ["fit", "{P}/realdata-skyderby-411"],
    ["fit", "{P}/realdata-fs2-chicago-kinematic"],
    ["joint", "{P}/ees-drop-1", "{P}/ees-drop-2", "--no-single"],
    ["simulate", "{P}/ees-drop-2"],
    ["sensitivity", "fisher", "{P}/ees-drop-2"],
    ["montecarlo", "{P}/ees-drop-2", "--cases", "4", "--workers", "1"],
])
def test_a_command_parses_each_problem_file_once(argv, parsed_files, tmp_path):
    args = [a.replace("{P}", str(PROBLEMS)) for a in argv]
    quiet = {"fit": ["--no-figures", "--quiet"], "joint": ["--no-figures", "--quiet"],
             "montecarlo": ["--no-figures", "--quiet"]}.get(argv[0], [])
    assert main([*args, "--out", str(tmp_path / "out"), *quiet]) == 0
    problems = [p for p in parsed_files if p.name == "problem.toml"]
    assert problems, "the count must see the problem files"
    assert sorted(problems) == sorted(set(problems)), f"parsed more than once: {problems}"


def test_a_six_dof_fit_reads_its_sounding_once(monkeypatch, tmp_path):
    """The scenario reads the sounding; the pre-solve data check takes it from there."""
    import casrecon.estimation.validation.data_checks as checks
    import casrecon.scenario as scenario

    reads: list[Path] = []
    real = scenario.read_sounding

    def counting(path, **kw):
        reads.append(Path(path))
        return real(path, **kw)

    monkeypatch.setattr(scenario, "read_sounding", counting)
    monkeypatch.setattr(checks, "read_sounding", counting)
    assert main(["fit", str(PROBLEMS / "ees-drop-2"), "--out", str(tmp_path / "out"), "--no-figures", "--quiet"]) == 0
    assert len(reads) == 1, reads
