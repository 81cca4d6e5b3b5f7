"""Issue 17, output safety: results are written only where casrecon owns the folder; inputs are never
replaced; an earlier result survives every failure (bad --out, failed fit, disk full, Ctrl-C,
SIGTERM, SIGKILL, concurrent writers); no temporary folder is left behind.

Almost every case fails before any solve, in this process (:func:`call_cli`); the signal cases run
``python -m casrecon montecarlo`` in a subprocess and signal it mid-run.
"""

from __future__ import annotations

import errno
import json
import multiprocessing
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from casrecon.output.out_folder import (
    MARKER,
    OutFolderError,
    ResultsWriteError,
    check_out_folder,
    clean_stale,
    input_paths,
)
from casrecon.output.results import atomic_folder, save_results_folder

from .conftest import (
    PROBLEMS,
    assert_clean_failure,
    call_cli,
    leftover_temp_folders,
    make_results_folder,
    run_cli,
    start_cli,
    tree_checksums,
    wait_for_handlers,
)

#: Each writing command on problem ``P`` (cheap options; every case here fails before any work).
WRITERS = {
    "fit": ["fit", "{P}", "--no-figures", "--quiet"],
    "simulate": ["simulate", "{P}", "--every", "500"],
    "joint": ["joint", "{P}", "{P}", "--no-single", "--no-figures"],
    "montecarlo": ["montecarlo", "{P}", "--cases", "2", "--workers", "1", "--no-figures"],
    "estimator": ["montecarlo", "{P}", "--estimator", "--cases", "2", "--workers", "1"],
    "fisher": ["sensitivity", "fisher", "{P}"],
    "profile": ["sensitivity", "profile", "{P}"],
}


def command(name: str, problem: Path, out, *extra) -> list[str]:
    return [a.replace("{P}", str(problem)) for a in WRITERS[name]] + ["--out", str(out), *extra]


# ---------------------------------------------------------------- inputs are never replaced


def test_issue_repro_fit_into_its_own_problem_folder_is_refused(realdata_problem):
    """The issue's reproduction: ``casrecon fit X --out X`` replaced X, raw data included."""
    before = tree_checksums(realdata_problem)
    proc = run_cli("fit", realdata_problem, "--out", realdata_problem, "--no-figures", "--quiet")
    assert_clean_failure(proc, 2, str(realdata_problem), "input")
    assert tree_checksums(realdata_problem) == before
    assert leftover_temp_folders(realdata_problem.parent) == []


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_every_writer_refuses_the_problem_folder_as_out(name, drop_problem, capsys):
    root = drop_problem.parent
    before = tree_checksums(root)
    proc = call_cli(capsys, *command(name, drop_problem, drop_problem))
    assert_clean_failure(proc, 2, "input", "never")
    assert tree_checksums(root) == before
    assert leftover_temp_folders(root.parent) == []


@pytest.mark.parametrize("where", ["problem folder", "its parent", "problem.toml", "data folder", "imu file",
                                   "shared vehicles folder", "grandparent"])
def test_force_never_replaces_inputs(where, drop_problem, capsys):
    out = {"problem folder": drop_problem, "its parent": drop_problem.parent,
           "problem.toml": drop_problem / "problem.toml", "data folder": drop_problem / "data",
           "imu file": drop_problem / "data" / "imu.csv", "shared vehicles folder": drop_problem.parent / "vehicles",
           "grandparent": drop_problem.parent.parent}[where]
    root = drop_problem.parent.parent
    before = tree_checksums(root)
    proc = call_cli(capsys, *command("simulate", drop_problem, out, "--force"))
    assert_clean_failure(proc, 2, "never replace")
    assert tree_checksums(root) == before


@pytest.mark.parametrize("cwd", ["problem folder", "problems folder", "unrelated work folder"])
def test_out_dot_never_replaces_the_working_directory(cwd, drop_problem, capsys, monkeypatch):
    work = drop_problem.parent.parent / "work"
    work.mkdir()
    (work / "notes.txt").write_text("someone's work\n")
    here = {"problem folder": drop_problem, "problems folder": drop_problem.parent, "unrelated work folder": work}[cwd]
    monkeypatch.chdir(here)
    root = drop_problem.parent.parent
    before = tree_checksums(root)
    proc = call_cli(capsys, *command("simulate", drop_problem, ".", "--force"))
    assert_clean_failure(proc, 2, "never replace")
    assert tree_checksums(root) == before


def test_a_new_folder_inside_the_problem_folder_is_fine(drop_problem, capsys):
    before = tree_checksums(drop_problem)
    proc = call_cli(capsys, *command("simulate", drop_problem, drop_problem / "results"))
    assert proc.returncode == 0, proc.stderr
    after = tree_checksums(drop_problem)
    assert {k: v for k, v in after.items() if not k.startswith("results")} == before
    assert (drop_problem / "results" / MARKER).is_file()


def test_simulate_data_may_regenerate_the_data_folder_it_made(drop_problem, capsys):
    """problems/*/data was written by ``simulate --data``: regenerating it is allowed (the sensor files
    are that command's outputs), but no other command, nor ``simulate`` without ``--data``, replaces it."""
    data = drop_problem / "data"
    before, toml = tree_checksums(data), tree_checksums(drop_problem / "problem.toml")
    refused = call_cli(capsys, *command("simulate", drop_problem, data))
    assert_clean_failure(refused, 2, "holds the input")
    assert tree_checksums(data) == before
    proc = call_cli(capsys, *command("simulate", drop_problem, data, "--data"))
    assert proc.returncode == 0, proc.stderr
    assert {"imu.csv", "gps.csv", "truth.json", MARKER} <= {p.name for p in data.iterdir()}
    assert tree_checksums(drop_problem / "problem.toml") == toml


def test_inputs_of_a_joint_file_are_protected(tmp_path):
    """A joint .toml names its drops; each drop's folder, its problem.toml and the files it names are inputs."""
    joint = tmp_path / "campaign" / "joint.toml"
    joint.parent.mkdir()
    drop = tmp_path / "campaign" / "d1"
    drop.mkdir()
    (drop / "problem.toml").write_text('[sensors.imu]\nfile = "imu.csv"\n')
    (drop / "imu.csv").write_text("t\n")
    joint.write_text('[joint]\ndrops = ["d1"]\n')
    found = set(input_paths([joint]))
    assert {joint.resolve(), drop.resolve(), (drop / "problem.toml").resolve(), (drop / "imu.csv").resolve()} <= found
    with pytest.raises(OutFolderError, match="never replace"):
        check_out_folder(drop, inputs=found, force=True)


# ---------------------------------------------------------------- foreign folders, files, legacy folders


@pytest.mark.parametrize("name", ["fit", "simulate", "montecarlo", "fisher", "joint"])
def test_a_folder_casrecon_did_not_write_needs_force(name, drop_problem, tmp_path, capsys):
    out = tmp_path / "campaign"
    out.mkdir()
    (out / "notes.txt").write_text("a week of work\n")
    before = tree_checksums(out)
    proc = call_cli(capsys, *command(name, drop_problem, out))
    assert_clean_failure(proc, 2, str(out), "--force", MARKER)
    assert tree_checksums(out) == before


@pytest.mark.parametrize("name", ["fit", "simulate"])
def test_an_existing_file_as_out_needs_force(name, drop_problem, tmp_path, capsys):
    out = tmp_path / "result.txt"
    out.write_text("not a folder\n")
    proc = call_cli(capsys, *command(name, drop_problem, out))
    assert_clean_failure(proc, 2, "is a file", "--force")
    assert out.read_text() == "not a folder\n"


def test_force_replaces_a_foreign_folder(drop_problem, tmp_path, capsys):
    out = tmp_path / "campaign"
    out.mkdir()
    (out / "notes.txt").write_text("replace me\n")
    proc = call_cli(capsys, *command("simulate", drop_problem, out, "--force"))
    assert proc.returncode == 0, proc.stderr
    assert not (out / "notes.txt").exists() and (out / "summary.json").is_file() and (out / MARKER).is_file()
    assert leftover_temp_folders(tmp_path) == []


def test_force_replaces_a_file(drop_problem, tmp_path, capsys):
    out = tmp_path / "result"
    out.write_text("a file\n")
    proc = call_cli(capsys, *command("simulate", drop_problem, out, "--force"))
    assert proc.returncode == 0, proc.stderr
    assert out.is_dir() and (out / MARKER).is_file()
    assert leftover_temp_folders(tmp_path) == []


def test_marker_is_written_and_an_own_folder_is_replaced_without_force(drop_problem, tmp_path, capsys):
    out = tmp_path / "sim"
    assert call_cli(capsys, *command("simulate", drop_problem, out)).returncode == 0
    marker = json.loads((out / MARKER).read_text())
    assert marker["written_by"] == "casrecon" and marker["kind"] == "simulate"
    assert marker["written_utc"].endswith("Z") and marker["casrecon_version"]
    (out / "stale.txt").write_text("from the earlier run\n")
    assert call_cli(capsys, *command("simulate", drop_problem, out)).returncode == 0
    assert not (out / "stale.txt").exists() and (out / "trajectory.csv").is_file()
    assert leftover_temp_folders(tmp_path) == []


def test_a_result_of_an_older_casrecon_is_replaced_without_force(drop_problem, tmp_path, capsys):
    """Decision: a folder without the marker but with a casrecon signature file (summary.json,
    statistics.json, nees.json, fisher.json, design.json holding casrecon's keys) and no problem.toml
    was written by an older casrecon, and is replaced; an empty folder too."""
    out = tmp_path / "old-result"
    make_results_folder(out, marker=False)
    assert call_cli(capsys, *command("simulate", drop_problem, out)).returncode == 0
    assert (out / MARKER).is_file() and not (out / "report.txt").exists()
    empty = tmp_path / "empty"
    empty.mkdir()
    assert call_cli(capsys, *command("simulate", drop_problem, empty)).returncode == 0


@pytest.mark.parametrize("name, content", [("summary.json", '{"total": 3}'), ("summary.json", "not json"),
                                           ("statistics.json", '{"mean": 1}'), ("fisher.json", "[]")])
def test_a_users_own_json_does_not_pass_for_a_casrecon_result(name, content, drop_problem, tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / name).write_text(content)
    before = tree_checksums(out)
    assert_clean_failure(call_cli(capsys, *command("simulate", drop_problem, out)), 2, "--force")
    assert tree_checksums(out) == before


def test_a_problem_folder_that_looks_like_a_result_is_refused(drop_problem, tmp_path, capsys):
    other = tmp_path / "other-problem"
    make_results_folder(other, marker=False)
    (other / "problem.toml").write_text("[problem]\n")
    before = tree_checksums(other)
    assert_clean_failure(call_cli(capsys, *command("simulate", drop_problem, other)), 2, "--force")
    assert tree_checksums(other) == before


@pytest.mark.parametrize("link_to", ["foreign folder", "input folder"])
def test_a_symlink_out_is_judged_by_its_target(link_to, drop_problem, tmp_path, capsys):
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "x.txt").write_text("x\n")
    link = tmp_path / "link"
    link.symlink_to(foreign if link_to == "foreign folder" else drop_problem)
    root = tmp_path
    before = tree_checksums(root)
    extra = () if link_to == "foreign folder" else ("--force",)
    proc = call_cli(capsys, *command("simulate", drop_problem, link, *extra))
    assert_clean_failure(proc, 2, str(link))
    assert tree_checksums(root) == before


# ---------------------------------------------------------------- unwritable locations, before any work


def test_out_under_a_file_is_refused_in_milliseconds(drop_problem, tmp_path, capsys):
    blocker = tmp_path / "afile"
    blocker.write_text("x\n")
    t0 = time.perf_counter()
    with pytest.raises(OutFolderError, match="is a file"):
        check_out_folder(blocker / "sub" / "out")
    assert time.perf_counter() - t0 < 0.5
    assert_clean_failure(call_cli(capsys, *command("fit", drop_problem, blocker / "out")), 2, "is a file")
    assert blocker.read_text() == "x\n"


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="Linux /proc")
def test_out_in_an_unwritable_location_is_refused(drop_problem, capsys):
    """/proc refuses new folders even to root (a read-only folder does not stop root)."""
    proc = call_cli(capsys, *command("fit", drop_problem, "/proc/casrecon-results/out"))
    assert_clean_failure(proc, 2, "cannot be written")


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes into read-only folders")
def test_out_in_a_read_only_folder_is_refused(drop_problem, tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert_clean_failure(call_cli(capsys, *command("fit", drop_problem, ro / "out")), 2, "cannot be written")
    finally:
        ro.chmod(0o755)


# ---------------------------------------------------------------- failures while computing or writing


@pytest.mark.parametrize("study", ["fisher", "profile"])
def test_failed_sensitivity_fit_keeps_the_earlier_result(study, drop_problem, tmp_path, capsys, monkeypatch):
    """It used to return from inside the atomic block: an empty folder replaced the earlier result."""
    from casrecon.estimation.sixdof import fit

    def failing_fit(*args, **kwargs):
        raise fit.FitError("Ipopt did not converge (test)")

    monkeypatch.setattr(fit, "fit_drop", failing_fit)
    out = tmp_path / "sens"
    earlier = make_results_folder(out, kind="sensitivity")
    proc = call_cli(capsys, *command(study, drop_problem, out))
    assert_clean_failure(proc, 3, "did not converge")
    assert tree_checksums(out) == earlier
    assert leftover_temp_folders(tmp_path) == []


@pytest.mark.parametrize("module, writer", [("casrecon.output.simulation_results", "write_table"),
                                            ("casrecon.output.results", "write_json"),
                                            ("casrecon.output.results", "write_marker")])
def test_disk_full_while_writing_keeps_the_earlier_result(module, writer, drop_problem, tmp_path, capsys, monkeypatch):
    import importlib

    results = importlib.import_module(module)  # the namespace the simulate command's writer is looked up in
    real = getattr(results, writer)

    def full(path, *args, **kwargs):
        real(path, *args, **kwargs)  # part of the file is written, then the disk is full
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(results, writer, full)
    out = tmp_path / "sim"
    earlier = make_results_folder(out)
    proc = call_cli(capsys, *command("simulate", drop_problem, out))
    assert_clean_failure(proc, 2, "cannot write", str(out), "No space left on device")
    assert tree_checksums(out) == earlier
    assert leftover_temp_folders(tmp_path) == []


def test_disk_full_in_a_new_deep_folder_leaves_nothing(tmp_path):
    target = tmp_path / "a" / "b" / "out"

    def write(out: Path) -> None:
        (out / "x.csv").write_text("half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(ResultsWriteError) as err:
        save_results_folder(target, "test", write, None)
    assert isinstance(err.value, OSError) and err.value.errno == errno.ENOSPC and err.value.filename == str(target)
    assert list(tmp_path.iterdir()) == []  # the temporary folder and the parents made for it are gone


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_signal_while_writing_keeps_the_earlier_result(sig, drop_problem, tmp_path, capsys, monkeypatch):
    import casrecon.output.results as results

    def interrupted(path, *args, **kwargs):
        Path(path).write_text("{")  # half a file, then Ctrl-C or SIGTERM
        os.kill(os.getpid(), sig)
        time.sleep(5)  # the handler raises before this ends

    monkeypatch.setattr(results, "write_json", interrupted)
    out = tmp_path / "sim"
    earlier = make_results_folder(out)
    proc = call_cli(capsys, *command("simulate", drop_problem, out))
    assert_clean_failure(proc, 128 + sig, "interrupted; earlier results in", str(out), "kept")
    assert tree_checksums(out) == earlier
    assert leftover_temp_folders(tmp_path) == []


@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="Linux /proc to see the handlers")
@pytest.mark.parametrize("sig, workers", [(signal.SIGINT, 1), (signal.SIGTERM, 1), (signal.SIGINT, 2),
                                          (signal.SIGTERM, 2)])
def test_signal_during_a_run_exits_128_plus_signal_and_keeps_the_earlier_result(sig, workers, tmp_path):
    out = tmp_path / "mc"
    earlier = make_results_folder(out, kind="montecarlo")
    proc = start_cli("montecarlo", PROBLEMS / "ees-drop-2", "--out", out, "--cases", "100000", "--workers",
                     workers, "--no-figures")
    try:
        assert wait_for_handlers(proc), proc.communicate()[1]
        time.sleep(1.0)  # into the cases
        t0 = time.monotonic()
        proc.send_signal(sig)
        stdout, stderr = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert time.monotonic() - t0 < 15
    done = subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)
    assert_clean_failure(done, 128 + sig, "interrupted; earlier results in", "kept")
    assert tree_checksums(out) == earlier
    assert leftover_temp_folders(tmp_path) == []


SWALLOWING = """
import sys, time
import casrecon.cli_guard as guard
from casrecon.output.results import atomic_folder
guard.GRACE_S = {grace}
def swallow(args):
    with atomic_folder(args.out) as tmp:
        (tmp / "half.csv").write_text("half")
        print("ready", flush=True)
        while True:  # a library that catches everything
            try:
                time.sleep(0.05)
            except BaseException:
                pass
class Args:
    out = sys.argv[1]
guard.exit_process(guard.run_command(swallow, Args()))
"""


@pytest.mark.parametrize("sig, second", [(signal.SIGTERM, False), (signal.SIGINT, True)])
def test_a_swallowed_interrupt_still_ends_the_run(sig, second, tmp_path):
    """A library that swallows the exception cannot keep the run alive: GRACE_S after the signal (or at
    a second signal) the temporary folder is removed and the process exits with 128 + signal."""
    out = tmp_path / "out"
    earlier = make_results_folder(out)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(PROBLEMS.parent), os.environ.get("PYTHONPATH", "")])}
    child = subprocess.Popen([sys.executable, "-c", SWALLOWING.format(grace=30.0 if second else 1.0), str(out)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert child.stdout.readline().strip() == "ready"
        t0 = time.monotonic()
        child.send_signal(sig)
        if second:
            time.sleep(0.5)
            child.send_signal(sig)
        _, stderr = child.communicate(timeout=20)
    finally:
        if child.poll() is None:
            child.kill()
    assert time.monotonic() - t0 < 10
    done = subprocess.CompletedProcess(child.args, child.returncode, "", stderr)
    assert_clean_failure(done, 128 + sig, "interrupted; earlier results in", "kept")
    assert tree_checksums(out) == earlier
    assert leftover_temp_folders(tmp_path) == []


# ---------------------------------------------------------------- leftovers of killed runs, concurrent writers


def dead_pid() -> int:
    """The id of a process that has ended."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_next_run_removes_temp_folders_of_a_killed_run(drop_problem, tmp_path, capsys):
    out = tmp_path / "sim"
    make_results_folder(out)
    pid = dead_pid()
    for kind in ("tmp", "old"):
        stale = tmp_path / f".sim.{kind}-{pid}-abcd1234"
        stale.mkdir()
        (stale / "half.csv").write_text("half\n")
    other = tmp_path / f".other.tmp-{pid}-abcd1234"  # another target's: not this run's business
    other.mkdir()
    assert call_cli(capsys, *command("simulate", drop_problem, out)).returncode == 0
    assert leftover_temp_folders(tmp_path) == [other]


def test_temp_folder_of_a_live_writer_is_kept(tmp_path):
    target = tmp_path / "out"
    live = tmp_path / f".out.tmp-{os.getppid()}-abcd1234"
    live.mkdir()
    assert clean_stale(target) == [] and live.is_dir()


def test_backup_is_put_back_when_a_kill_came_between_the_renames(tmp_path):
    target = tmp_path / "out"
    pid = dead_pid()
    backup = tmp_path / f".out.old-{pid}-abcd1234"
    earlier = make_results_folder(backup)
    half = tmp_path / f".out.tmp-{pid}-abcd1234"
    half.mkdir()
    clean_stale(target)
    assert tree_checksums(target) == earlier
    assert leftover_temp_folders(tmp_path) == []


def test_sigkill_while_writing_then_the_next_run_cleans_up(tmp_path):
    target = tmp_path / "out"
    earlier = make_results_folder(target)
    script = ("import sys, time\nfrom casrecon.output.results import atomic_folder\n"
              f"with atomic_folder({str(target)!r}) as tmp:\n"
              "    (tmp / 'half.csv').write_text('half')\n    print('ready', flush=True)\n    time.sleep(60)\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(PROBLEMS.parent), os.environ.get("PYTHONPATH", "")])}
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert child.stdout.readline().strip() == "ready"
        child.kill()
        child.wait(timeout=10)
    finally:
        if child.poll() is None:
            child.kill()
    assert len(leftover_temp_folders(tmp_path)) == 1  # what SIGKILL leaves
    assert tree_checksums(target) == earlier
    with atomic_folder(target) as tmp:
        (tmp / "new.txt").write_text("new")
    assert leftover_temp_folders(tmp_path) == []
    assert (target / "new.txt").read_text() == "new"


def write_together(target: str, barrier, label: str) -> None:
    """One of several writers of ``target`` that finish at the same moment (top level: picklable)."""
    with atomic_folder(target) as tmp:
        (tmp / "who.txt").write_text(label)
        (tmp / "data.csv").write_text("x\n" * 1000)
        barrier.wait(timeout=30)


def test_writers_finishing_together_in_threads(tmp_path):
    target = tmp_path / "out"
    for round_ in range(15):
        barrier = threading.Barrier(3)
        errors: list[BaseException] = []

        def run(label: str, barrier=barrier, errors=errors) -> None:
            try:
                write_together(str(target), barrier, label)
            except BaseException as err:  # noqa: BLE001 - collected for the assertion
                errors.append(err)

        threads = [threading.Thread(target=run, args=(f"{round_}-{k}",)) for k in range(3)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=60)
        assert errors == []
        assert (target / "who.txt").read_text().startswith(f"{round_}-")
        assert sorted(p.name for p in target.iterdir()) == [MARKER, "data.csv", "who.txt"]
        assert leftover_temp_folders(tmp_path) == []


def test_writers_finishing_together_in_processes(tmp_path):
    target = tmp_path / "out"
    make_results_folder(target)
    ctx = multiprocessing.get_context("spawn")
    barrier = ctx.Barrier(2)
    procs = [ctx.Process(target=write_together, args=(str(target), barrier, f"p{k}")) for k in range(2)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(timeout=120)
    assert [p.exitcode for p in procs] == [0, 0]
    assert (target / "who.txt").read_text() in ("p0", "p1")
    assert leftover_temp_folders(tmp_path) == []


# ---------------------------------------------------------------- the Python API's save


def test_api_save_refuses_a_foreign_folder_unless_forced(tmp_path):
    out = tmp_path / "campaign"
    out.mkdir()
    (out / "notes.txt").write_text("keep\n")

    def write(folder: Path) -> None:
        (folder / "summary.json").write_text("{}\n")

    with pytest.raises(OutFolderError, match="force"):
        save_results_folder(out, "test", write, None, kind="fit")
    assert (out / "notes.txt").read_text() == "keep\n"
    save_results_folder(out, "test", write, None, kind="fit", force=True)
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "summary.json"]


def test_api_save_never_replaces_inputs(drop_problem):
    before = tree_checksums(drop_problem.parent)
    with pytest.raises(OutFolderError, match="never replace"):
        save_results_folder(drop_problem.parent, "test", lambda out: None, None, force=True,
                            inputs=input_paths([drop_problem]))
    assert tree_checksums(drop_problem.parent) == before
