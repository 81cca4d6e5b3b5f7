"""fit_products(concurrent=True), as ``casrecon fit`` runs it (the nominal simulation with the
verdict, and the aerodynamic coefficients, in forked children), gives exactly the sequential
products. An 8 s window of ees-drop-1 keeps the fit to a few seconds."""

from __future__ import annotations

import dataclasses

import numpy as np
from conftest import short_window

from casrecon.analysis.fit_products import fit_products
from casrecon.estimation.sixdof.fit import fit_drop


def assert_same(a, b, where: str) -> None:
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            assert_same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where)
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{k}]")
    else:
        assert a == b or (a != a and b != b), where  # NaN equals NaN here


def test_concurrent_products_equal_the_sequential_ones():
    result = fit_drop(short_window("ees-drop-1", 3.0, 8.0))
    sequential, concurrent = fit_products(result), fit_products(result, concurrent=True)
    for field in dataclasses.fields(sequential):
        if field.name == "adequacy":
            continue
        assert_same(getattr(sequential, field.name), getattr(concurrent, field.name), field.name)
    assert sequential.adequacy.to_dict() == concurrent.adequacy.to_dict()
