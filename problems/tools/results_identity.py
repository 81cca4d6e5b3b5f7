"""Fit every shipped problem through the command line and compare results folders file by file.

Usage::

    python problems/tools/results_identity.py write OUT [--only NAME ...] [--figures]
    python problems/tools/results_identity.py compare OLD NEW

``write`` runs ``casrecon fit PROBLEM --out OUT/NAME --no-figures`` for every folder of ``problems/``
with a ``problem.toml``, and ``casrecon joint problems/ees-joint.toml --out OUT/ees-joint``.
``compare`` says, for every results file of two such trees, whether it is byte-identical, identical
but for timings (the ``timings`` table and its copies, durations "12.3 s" in notes and reports, the
``.casrecon-results.json`` marker's time stamp and version; the source tree's and the output tree's
paths read as ``<ROOT>`` and ``<OUT>``), or different, and exits 1 when any file differs. The commands'
stdout (``NAME.log``) is kept beside the folders but not compared. Used to show that a restructuring
changes no number.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: JSON keys whose values are wall-clock measurements or stamps, not results: the ``timings`` table and
#: its copies at the top of summary.json, wall times, the marker's time stamp and version.
TIMING_KEYS = re.compile(r"^(timings|build_s|solve_s|covariance_s|total_s|fit_s|wall_time_s|wall_s|written_utc|"
                         r"casrecon_version|version)$")
#: File (in an output tree) that records which source tree wrote it: its paths are compared as <ROOT>.
ROOT_FILE = "_root.txt"


def shipped_problems() -> list[Path]:
    """Every folder of problems/ holding a problem.toml, sorted."""
    return sorted(p.parent for p in (ROOT / "problems").glob("*/problem.toml"))


def write(out: Path, only: list[str], figures: bool) -> int:
    out.mkdir(parents=True, exist_ok=True)
    (out / ROOT_FILE).write_text(f"{ROOT}\n{out.resolve()}\n")
    jobs = [(p.name, ["fit", str(p)]) for p in shipped_problems()]
    jobs.append(("ees-joint", ["joint", str(ROOT / "problems" / "ees-joint.toml")]))
    status = 0
    for name, command in jobs:
        if only and name not in only:
            continue
        t0 = time.perf_counter()
        args = [sys.executable, "-m", "casrecon", *command, "--out", str(out / name), "--force", "--quiet"]
        if not figures:
            args.append("--no-figures")
        run = subprocess.run(args, capture_output=True, text=True)
        print(f"{name}: exit {run.returncode}, {time.perf_counter() - t0:.1f} s", flush=True)
        (out / f"{name}.log").write_text(run.stdout + run.stderr)
        status |= run.returncode != 0
    return status


def _strip(doc):
    if isinstance(doc, dict):
        return {k: _strip(v) for k, v in doc.items() if not TIMING_KEYS.search(k)}
    if isinstance(doc, list):
        return [_strip(v) for v in doc]
    return doc


def same_but_timings(a: Path, b: Path, roots: tuple[list[str], list[str]]) -> bool:
    """Whether two files agree once their source and output roots read ``<ROOT>``/``<OUT>`` and their
    timings are left out."""
    try:
        text_a, text_b = a.read_text(), b.read_text()
    except UnicodeDecodeError:
        return False
    for i, (old, new) in enumerate(zip(*roots)):
        tag = ("<ROOT>", "<OUT>")[i]
        text_a, text_b = text_a.replace(old, tag), text_b.replace(new, tag)
    drop = re.compile(r"(\(total [0-9.]+ s\)|\d+\.\d+ s\b)")  # durations in notes and reports
    text_a, text_b = drop.sub("", text_a), drop.sub("", text_b)
    if a.suffix == ".json":
        try:
            return _strip(json.loads(text_a)) == _strip(json.loads(text_b))
        except json.JSONDecodeError:
            return False
    return text_a == text_b


def verdicts(old: Path, new: Path, roots: tuple[list[str], list[str]] = ([], [])) -> dict[Path, str]:
    """Every results file of two trees (relative path) with its verdict: "identical", "timings only",
    "different" or "missing" (in one tree only); ``roots``: each tree's source and output roots, read
    as ``<ROOT>`` and ``<OUT>`` (:data:`ROOT_FILE`). The commands' logs and the root files are left out."""
    names = sorted(p for p in ({p.relative_to(old) for p in old.rglob("*") if p.is_file()}
                               | {p.relative_to(new) for p in new.rglob("*") if p.is_file()})
                   if p != Path(ROOT_FILE) and p.suffix != ".log")  # the logs are the commands' stdout
    out = {}
    for rel in names:
        a, b = old / rel, new / rel
        if not a.is_file() or not b.is_file():
            out[rel] = "missing"
        elif a.read_bytes() == b.read_bytes():
            out[rel] = "identical"
        else:
            out[rel] = "timings only" if same_but_timings(a, b, roots) else "different"
    return out


def compare(old: Path, new: Path) -> int:
    roots = tuple((tree / ROOT_FILE).read_text().split() if (tree / ROOT_FILE).is_file() else []
                  for tree in (old, new))
    counts = {"identical": 0, "timings only": 0, "different": 0, "missing": 0}
    for rel, verdict in verdicts(old, new, roots).items():
        counts[verdict] += 1
        if verdict in ("different", "missing"):
            print(f"{verdict}: {rel}")
    print(", ".join(f"{n} {k}" for k, n in counts.items()))
    return 1 if counts["different"] or counts["missing"] else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("write")
    p.add_argument("out", type=Path)
    p.add_argument("--only", nargs="*", default=[])
    p.add_argument("--figures", action="store_true")
    p = sub.add_parser("compare")
    p.add_argument("old", type=Path)
    p.add_argument("new", type=Path)
    args = parser.parse_args()
    if args.command == "write":
        return write(args.out, args.only, args.figures)
    return compare(args.old, args.new)


if __name__ == "__main__":
    sys.exit(main())
