"""atomic_folder: a results folder is replaced only when writing it succeeded (the ownership rules and
the failure paths are in tests/reliability/test_output_safety.py); json_values: what a fresh result
holds equals what its JSON files read back."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from casrecon.output.out_folder import MARKER
from casrecon.output.results import atomic_folder, json_values, to_builtin, write_columns, write_json


def leftovers(parent):
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


def test_creates_folder(tmp_path):
    target = tmp_path / "deep" / "out"
    with atomic_folder(target) as tmp:
        assert tmp != target and not target.exists()  # nothing visible while writing
        (tmp / "a.txt").write_text("new")
    assert (target / "a.txt").read_text() == "new"
    assert json.loads((target / MARKER).read_text())["kind"] == "results"
    assert leftovers(target.parent) == []


def test_replaces_existing_folder_on_success(tmp_path):
    target = tmp_path / "out"
    target.mkdir()
    (target / "old.txt").write_text("old")
    (target / MARKER).write_text("{}")
    with atomic_folder(target, kind="fit") as tmp:
        (tmp / "new.txt").write_text("new")
        assert (target / "old.txt").exists()  # the old result stays until the swap
    assert sorted(p.name for p in target.iterdir()) == [MARKER, "new.txt"]
    assert leftovers(tmp_path) == []


def test_exception_keeps_existing_folder_and_cleans_up(tmp_path):
    target = tmp_path / "out"
    target.mkdir()
    (target / "old.txt").write_text("old")
    (target / MARKER).write_text("{}")
    with pytest.raises(RuntimeError, match="boom"):
        with atomic_folder(target) as tmp:
            (tmp / "half.txt").write_text("half")
            raise RuntimeError("boom")
    assert sorted(p.name for p in target.iterdir()) == [MARKER, "old.txt"]
    assert (target / "old.txt").read_text() == "old"
    assert leftovers(tmp_path) == []  # no temporary folder left behind


def test_exception_without_existing_folder_creates_nothing(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with atomic_folder(tmp_path / "out"):
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_writers(tmp_path):
    write_json(tmp_path / "a.json", {"x": np.float64(1.5), "v": np.arange(3)})
    assert json.loads((tmp_path / "a.json").read_text()) == {"x": 1.5, "v": [0, 1, 2]}
    write_columns(tmp_path / "t.csv", ["a", "b"], np.array([[1.0, 2.5], [3.0, 4.0]]))
    assert (tmp_path / "t.csv").read_text() == "a,b\n1,2.5\n3,4\n"


# ---- json_values: a fresh result holds what its JSON files read back, without the text ----------
_leaves = st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12), st.floats(allow_nan=False),
                    st.text(max_size=5),
                    st.floats(allow_nan=False).map(np.float64), st.integers(-1000, 1000).map(np.int64),
                    st.booleans().map(np.bool_), st.lists(st.floats(allow_nan=False), max_size=3).map(np.array))
_keys = st.one_of(st.text(max_size=4), st.integers(-5, 5), st.booleans(), st.none(), st.floats(allow_nan=False))
_trees = st.recursive(_leaves, lambda inner: st.one_of(st.lists(inner, max_size=3), st.tuples(inner, inner),
                                                      st.dictionaries(_keys, inner, max_size=3)), max_leaves=12)


@given(_trees)
def test_json_values_equal_what_the_json_text_reads_back(tree):
    expected = json.loads(json.dumps(tree, default=to_builtin))
    got = json_values(tree)
    assert got == expected
    assert json.dumps(got) == json.dumps(expected)  # the same types (1 and 1.0, True and 1 differ in text)
