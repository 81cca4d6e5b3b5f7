"""The README is an entrance and the documentation's links hold.

README.md stays short (at most 300 lines), states no dated measurement (no ISO date) and no commit
hash (a measurement that needs a date or a commit belongs on a dated page under docs/studies/ or in
benchmarks/RESULTS.md), and keeps the test command CI runs (`.ci/run`). Every relative markdown link
in README.md, docs/**/*.md and benchmarks/RESULTS.md points at a file that exists, and a link to a
heading (`page.md#anchor`) at a heading that exists (GitHub's anchors)."""

from __future__ import annotations

import re
import unicodedata
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
README = REPO / "README.md"
TEST_COMMAND = ("python3 -m venv .venv && .venv/bin/pip install -q -e '.[test]' && "
                ".venv/bin/python -m pytest -q")
MAX_README_LINES = 300

ISO_DATE = re.compile(r"\b\d{4}-\d{2}-\d{2}\b")
HEX = re.compile(r"\b[0-9a-f]{7,40}\b", re.IGNORECASE)
FENCE = re.compile(r"^(```|~~~).*?^\1[ \t]*$", re.MULTILINE | re.DOTALL)
INLINE_CODE = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^#{1,6}[ \t]+(.+?)[ \t#]*$", re.MULTILINE)


def doc_files() -> list[Path]:
    """The markdown files whose links are checked."""
    files = [README, *sorted((REPO / "docs").rglob("*.md"))]
    results = REPO / "benchmarks" / "RESULTS.md"
    if results.is_file():
        files.append(results)
    return files


def _looks_like_hash(token: str) -> bool:
    return any(c.isdigit() for c in token) and any(c.isalpha() for c in token)


def commit_hashes(text: str) -> list[str]:
    """Hex tokens of 7 to 40 characters, with a digit and a letter, in backticks or after 'commit'."""
    found = [t for t in re.findall(r"`([0-9a-fA-F]{7,40})`", text) if _looks_like_hash(t)]
    for m in re.finditer(r"\bcommits?\b", text, re.IGNORECASE):
        window = text[m.end():m.end() + 60]
        found += [t for t in HEX.findall(window) if _looks_like_hash(t)]
    return found


def iso_dates(text: str) -> list[str]:
    return ISO_DATE.findall(text)


def without_code(text: str) -> str:
    """The text with fenced code blocks and inline code spans removed (links there are not links)."""
    return INLINE_CODE.sub("", FENCE.sub("", text))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: markup dropped, lower case, punctuation removed, spaces to '-'."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)       # a link in a heading: its text
    text = text.replace("`", "").strip().lower()
    kept = []
    for ch in text:
        cat = unicodedata.category(ch)
        if ch in " -_" or cat[0] in "LN" or cat == "Mn":
            kept.append(ch)
    return "".join(kept).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every heading anchor of a markdown file, with GitHub's -1, -2 suffixes for repeats."""
    seen: dict[str, int] = {}
    out = set()
    for m in HEADING.finditer(FENCE.sub("", path.read_text(encoding="utf-8"))):
        base = slug(m.group(1))
        n = seen.get(base, 0)
        out.add(base if n == 0 else f"{base}-{n}")
        seen[base] = n + 1
    return out


def broken_links(path: Path) -> list[str]:
    """Relative links of one markdown file whose target file (or heading) does not exist."""
    bad = []
    for target in LINK.findall(without_code(path.read_text(encoding="utf-8"))):
        if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target):          # http:, https:, mailto:
            continue
        file_part, _, fragment = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        if not dest.exists():
            bad.append(f"{target}: no such file")
            continue
        if fragment:
            page = dest / "README.md" if dest.is_dir() else dest
            if page.suffix == ".md" and page.is_file() and fragment.lower() not in anchors(page):
                bad.append(f"{target}: no heading with that anchor in {page.relative_to(REPO)}")
    return bad


def readme_problems(text: str) -> list[str]:
    """What makes a README text fail the entrance rules (empty when it passes)."""
    problems = []
    n = len(text.splitlines())
    if n > MAX_README_LINES:
        problems.append(f"{n} lines, more than {MAX_README_LINES}")
    if iso_dates(text):
        problems.append(f"dated measurements: {sorted(set(iso_dates(text)))[:5]}")
    if commit_hashes(text):
        problems.append(f"commit hashes: {sorted(set(commit_hashes(text)))[:5]}")
    if TEST_COMMAND not in text.splitlines():
        problems.append("the test command line CI runs is missing")
    return problems


def test_readme_at_most_300_lines():
    n = len(README.read_text(encoding="utf-8").splitlines())
    assert n <= MAX_README_LINES, f"README.md has {n} lines; move detail into docs/"


def test_readme_has_no_iso_date():
    assert iso_dates(README.read_text(encoding="utf-8")) == [], (
        "README.md states a dated measurement; put it on a dated page under docs/studies/")


def test_readme_has_no_commit_hash():
    assert commit_hashes(README.read_text(encoding="utf-8")) == [], (
        "README.md cites a commit; put it on a page under docs/studies/ or benchmarks/RESULTS.md")


def test_readme_keeps_the_test_command_ci_runs():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert TEST_COMMAND in lines, "README.md must keep the test command line that .ci/run mirrors"
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert TEST_COMMAND in ci, ".ci/run no longer runs the README's test command"


def test_readme_rules_in_one_place():
    assert readme_problems(README.read_text(encoding="utf-8")) == []


@pytest.mark.parametrize("path", doc_files(), ids=lambda p: str(p.relative_to(REPO)))
def test_relative_links_resolve(path):
    assert broken_links(path) == []


def test_the_checks_catch_what_they_should():
    """Hand cases for the detectors, so a passing README is not a detector that finds nothing."""
    assert commit_hashes("Side by side (commit 2e35c6e and 00aa92e, alternating)") == ["2e35c6e", "00aa92e"]
    assert commit_hashes("fixed in `fe73c67`") == ["fe73c67"]
    assert commit_hashes("`ees-drop-1`, `1234567`, `defaced`, 1e-8, the committed 0.025") == []
    assert iso_dates("measured on 2026-11-25 (idle)") == ["2026-11-25"]
    assert iso_dates("NEES 597.1 in [505.7, 638.0]") == []
    assert slug("Aero file (`[problem] aero`)") == "aero-file-problem-aero"
    assert slug("Synthetic data: the simulator's model errors") == "synthetic-data-the-simulators-model-errors"
    assert slug("Kinematic (IMU-driven) reconstruction") == "kinematic-imu-driven-reconstruction"
    too_long = "\n".join([TEST_COMMAND] + ["x"] * MAX_README_LINES)
    assert any("lines" in p for p in readme_problems(too_long))
    assert any("missing" in p for p in readme_problems("# casrecon\n"))
