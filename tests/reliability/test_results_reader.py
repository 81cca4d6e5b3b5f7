"""Damaged results folders (issue 51): ``casrecon report`` and ``casrecon.load_results`` read them through
one checked reader (casrecon.output.results_reader), so each kind of damage ends the same way in both:
one located line (the file, the line or key, what was expected) and exit 2 from the command line, a
located InputError from the API; nothing is written into the folder. A folder whose figures cannot be
written makes ``report`` exit 2 naming the folder, where it used to print 26 "skipped" lines and exit 0.
The folder is a real one: ees-drop-1 fitted once per session (``fitted_drop_folder``)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import casrecon

from .conftest import assert_clean_failure, call_cli, cli_env, leftover_temp_folders, tree_checksums


def cut_mid_row(path: Path) -> int:
    """Cut ``path`` in the middle of its 684th line (as a full disk or a killed copy would); its number."""
    lines = path.read_text().splitlines(keepends=True)
    keep = 683
    path.write_text("".join(lines[:keep]) + lines[keep][:len(lines[keep]) // 2])
    return keep + 1


def set_parameter(path: Path, key: str, value) -> None:
    doc = json.loads(path.read_text())
    doc["parameters"]["CA_mult"][key] = value
    path.write_text(json.dumps(doc, indent=2))  # json writes float("nan") as NaN, as a careless editor might


def damage(folder: Path, kind: str) -> tuple[str, ...]:
    """Damage ``folder`` one way; the fragments the located line must hold."""
    if kind == "cut trajectory row":
        line = cut_mid_row(folder / "trajectory.csv")
        return (f"trajectory.csv:{line}:", "cut mid-line")
    if kind == "NaN parameter value":
        set_parameter(folder / "parameters.json", "value", float("nan"))
        return ("parameters.json:", "field 'parameters.CA_mult.value'", "expected a finite number", "nan")
    if kind == "sigma abc":
        set_parameter(folder / "parameters.json", "sigma", "abc")
        return ("parameters.json:", "field 'parameters.CA_mult.sigma'", "expected a finite number >= 0", "'abc'")
    if kind == "cut summary":
        text = (folder / "summary.json").read_text()
        (folder / "summary.json").write_text(text[:len(text) // 2])
        return ("summary.json:", "not valid JSON", "cut short")
    if kind == "empty summary":
        (folder / "summary.json").write_text("")
        return ("summary.json:", "empty file", "expected a JSON object")
    if kind == "list summary":
        (folder / "summary.json").write_text("[]\n")
        return ("summary.json:1:", "expected a JSON object", "found a JSON array")
    if kind == "binary trajectory":
        (folder / "trajectory.csv").write_bytes(bytes(range(256)) * 64)
        return ("trajectory.csv:", "not text", "binary")
    raise AssertionError(kind)


DAMAGE = ("cut trajectory row", "NaN parameter value", "sigma abc", "cut summary", "empty summary", "list summary",
          "binary trajectory")


@pytest.fixture
def folder(fitted_drop_folder, tmp_path) -> Path:
    """A fresh copy of the fitted ees-drop-1 folder."""
    out = tmp_path / "ees-drop-1"
    shutil.copytree(fitted_drop_folder, out)
    return out


@pytest.mark.parametrize("kind", DAMAGE)
def test_report_refuses_a_damaged_folder_with_one_located_line(folder, kind, capsys):
    fragments = damage(folder, kind)
    before = tree_checksums(folder)
    proc = call_cli(capsys, "report", folder)
    assert_clean_failure(proc, 2, str(folder), *fragments)
    assert tree_checksums(folder) == before and not leftover_temp_folders(folder)  # nothing (half-)written


@pytest.mark.parametrize("kind", DAMAGE)
def test_load_results_refuses_a_damaged_folder_with_a_located_input_error(folder, kind):
    fragments = damage(folder, kind)
    before = tree_checksums(folder)
    with pytest.raises(casrecon.InputError) as caught:
        casrecon.load_results(folder)
    line = str(caught.value)
    assert "\n" not in line and line.startswith(str(folder))
    for fragment in fragments:
        assert fragment.lower() in line.lower(), f"{fragment!r} not in {line!r}"
    assert tree_checksums(folder) == before


def make_joint(folder: Path, tmp_path: Path) -> Path:
    """A joint folder by hand from the fitted drop: drops/a and drops/b, the drop's parameters on top."""
    joint = tmp_path / "joint"
    for name in ("a", "b"):
        shutil.copytree(folder, joint / "drops" / name)
        summary = json.loads((joint / "drops" / name / "summary.json").read_text())
        (joint / "drops" / name / "summary.json").write_text(json.dumps({**summary, "problem": name}))
    shutil.copy(folder / "parameters.json", joint / "parameters.json")
    (joint / "summary.json").write_text(json.dumps({"name": "joint", "converged": True}))
    return joint


def test_a_damaged_drop_of_a_joint_folder_is_named_by_report_and_load_results(folder, tmp_path, capsys):
    joint = make_joint(folder, tmp_path)
    assert isinstance(casrecon.load_results(joint), casrecon.JointFit)  # the undamaged one loads
    line = cut_mid_row(joint / "drops" / "b" / "trajectory.csv")
    before = tree_checksums(joint)
    where = f"{joint / 'drops' / 'b' / 'trajectory.csv'}:{line}:"
    assert_clean_failure(call_cli(capsys, "report", joint), 2, where, "cut mid-line")
    with pytest.raises(casrecon.InputError, match=f"^{where} the last row is cut mid-line"):
        casrecon.load_results(joint)
    assert tree_checksums(joint) == before


def test_a_csv_row_with_a_cell_missing_or_not_a_number_is_located(folder):
    lines = (folder / "residuals_gps.csv").read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[5].split(",")
    cells[3] = "x1"
    lines[5] = ",".join(cells)
    (folder / "residuals_gps.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(casrecon.InputError, match=rf"residuals_gps.csv:6: field '{header[3]}': expected a number, "
                                                  r"found 'x1'"):
        casrecon.load_results(folder)
    lines[5] = ",".join(cells[:-1])
    (folder / "residuals_gps.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(casrecon.InputError, match=rf"residuals_gps.csv:6: {len(header) - 1} cells, "
                                                  rf"expected {len(header)}"):
        casrecon.load_results(folder)


def test_report_exits_2_naming_the_folder_when_its_figures_cannot_be_written(folder, capsys):
    """``figures`` is a file, so no figure can be written there, even by root (a read-only folder does
    not stop root): one line naming it, exit 2, nothing written (formerly 13 "skipped" lines, exit 0)."""
    (folder / "figures").write_text("not a folder\n")
    before = tree_checksums(folder)
    proc = call_cli(capsys, "report", folder)
    assert_clean_failure(proc, 2, str(folder / "figures"), "no figure written")
    assert tree_checksums(folder) == before and not leftover_temp_folders(folder)


@pytest.mark.skipif(sys.platform != "linux" or shutil.which("unshare") is None, reason="needs Linux unshare")
def test_report_on_a_read_only_file_system_exits_2_naming_the_folder(folder):
    """A read-only bind mount (in a user and mount namespace of its own) gives EROFS even to root."""
    probe = subprocess.run(["unshare", "-rm", "sh", "-c", f"mount -o bind,ro '{folder}' '{folder}'"],
                           capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"no read-only bind mount here: {probe.stderr.decode().strip()}")
    before = tree_checksums(folder)
    script = f"mount -o bind,ro '{folder}' '{folder}' && exec '{sys.executable}' -m casrecon report '{folder}'"
    proc = subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True, timeout=120,
                          env=cli_env())
    assert_clean_failure(proc, 2, str(folder / "figures"), "Read-only file system", "no figure written")
    assert tree_checksums(folder) == before


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes into read-only folders")
def test_report_on_a_read_only_folder_exits_2(folder, capsys):
    folder.chmod(0o555)
    try:
        proc = call_cli(capsys, "report", folder)
    finally:
        folder.chmod(0o755)
    assert_clean_failure(proc, 2, str(folder / "figures"), "no figure written")
