"""Fit every shipped problem through the command line and compare results folders file by file.

Usage::

    python problems/tools/results_identity.py write OUT [--only NAME ...] [--figures]
    python problems/tools/results_identity.py compare OLD NEW

``write`` runs ``casrecon fit PROBLEM --out OUT/NAME --no-figures`` for every folder of ``problems/``
with a ``problem.toml``, and ``casrecon joint problems/ees-joint.toml --out OUT/ees-joint``.
``compare`` says, for every file of two such trees, whether it is byte-identical, identical but for
timings (JSON keys ending in ``_s`` under ``timings``, ``wall_time_s``, ``total_s``; ``results -> ...
(total ... s)`` lines; the ``.casrecon-results.json`` marker's time stamp and version), or different, and
exits 1 when any file differs. Used to show that a restructuring changes no number.
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
#: JSON keys whose values are wall-clock measurements or stamps, not results.
TIMING_KEYS = re.compile(r"(^timings$|wall_time_s$|^total_s$|_time_s$|^created$|^written$|^version$|^casrecon$)")


def shipped_problems() -> list[Path]:
    """Every folder of problems/ holding a problem.toml, sorted."""
    return sorted(p.parent for p in (ROOT / "problems").glob("*/problem.toml"))


def write(out: Path, only: list[str], figures: bool) -> int:
    out.mkdir(parents=True, exist_ok=True)
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


def _same_but_timings(a: Path, b: Path) -> bool:
    if a.suffix == ".json":
        try:
            return _strip(json.loads(a.read_text())) == _strip(json.loads(b.read_text()))
        except (json.JSONDecodeError, UnicodeDecodeError):
            return False
    if a.suffix in (".txt", ".md", ".log"):
        drop = re.compile(r"(\d+\.\d+ s\b|total \S+ s|wall time.*)")
        return drop.sub("", a.read_text()) == drop.sub("", b.read_text())
    return False


def compare(old: Path, new: Path) -> int:
    names = sorted({p.relative_to(old) for p in old.rglob("*") if p.is_file()}
                   | {p.relative_to(new) for p in new.rglob("*") if p.is_file()})
    counts = {"identical": 0, "timings only": 0, "different": 0, "missing": 0}
    for rel in names:
        a, b = old / rel, new / rel
        if not a.is_file() or not b.is_file():
            verdict = "missing"
        elif a.read_bytes() == b.read_bytes():
            verdict = "identical"
        elif _same_but_timings(a, b):
            verdict = "timings only"
        else:
            verdict = "different"
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
