"""Shared argument checks: numbers, keys and the one output-suffix check every writer uses."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vptoolkit.checks import (
    changed_values,
    check_float,
    check_int,
    check_int_range,
    check_keys,
    check_suffix,
)
from vptoolkit.errors import InputError


def test_check_suffix_accepts_any_case_and_names_the_file(tmp_path):
    assert check_suffix(tmp_path / "a.NPZ", ".npz") == tmp_path / "a.NPZ"
    assert isinstance(check_suffix("b.png", ".png"), Path)
    with pytest.raises(InputError, match=r"^out.txt: output must end in \.npz$"):
        check_suffix(tmp_path / "out.txt", ".npz")
    with pytest.raises(InputError, match=r"^x: predictions must end in \.npz$"):
        check_suffix("x", ".npz", what="predictions")


def test_check_keys_names_the_missing_and_the_unknown_keys():
    assert check_keys({"a": 1, "b": 2}, ("a", "b"), "record") == {"a": 1, "b": 2}
    with pytest.raises(InputError, match="^record: missing b; unknown c, d$"):
        check_keys({"a": 1, "d": 0, "c": 0}, ("a", "b"), "record")
    with pytest.raises(InputError, match="^record: expected a mapping, got list$"):
        check_keys([], ("a",), "record")


def test_check_keys_may_let_keys_take_their_defaults():
    record = {"a": 1}
    checked = check_keys(record, ("a", "b"), "options", missing_ok=True)
    assert checked == record and checked is not record
    with pytest.raises(InputError, match="^options: unknown c$"):
        check_keys({"a": 1, "c": 0}, ("a", "b"), "options", missing_ok=True)


def test_changed_values_names_each_differing_key_nested_ones_by_their_path():
    before = {"seed": 0, "epochs": 4, "gone": 1, "measure": {"views": 1000, "resolution": 64}}
    now = {"seed": 0, "epochs": 5, "new": 2, "measure": {"views": 500, "resolution": 64}}
    assert changed_values(before, now) == {
        "epochs": (4, 5), "new": (None, 2), "measure.views": (1000, 500)}
    assert changed_values(now, now) == {}


def test_check_int_with_expected_words_every_refusal_alike():
    assert check_int(np.int64(3), "n", minimum=0, expected="a non-negative integer") == 3
    for value in (-1, 1.5, True, "2"):
        with pytest.raises(InputError, match="^n: expected a non-negative integer, got "):
            check_int(value, "n", minimum=0, expected="a non-negative integer")
    with pytest.raises(InputError, match="^n: expected a positive integer, got "):
        check_int(np.int64(3), "n", minimum=1, numpy=False, expected="a positive integer")
    with pytest.raises(InputError, match="^k: expected an integer from 1 to 5, got 6$"):
        check_int_range(6, "k", 1, 5)


def test_check_float_refuses_bools_non_finite_values_and_open_bounds():
    assert check_float(2, "lr", above=0.0, expected="a positive finite number") == 2.0
    assert check_float(0.0, "rate", minimum=0.0, below=1.0, expected="a rate in [0, 1)") == 0.0
    for value in (0, float("nan"), float("inf"), True, "1"):
        with pytest.raises(InputError, match="^lr: expected a positive finite number, got "):
            check_float(value, "lr", above=0.0, expected="a positive finite number")
    with pytest.raises(InputError, match=r"^rate: expected a rate in \[0, 1\), got 1.0$"):
        check_float(1.0, "rate", minimum=0.0, below=1.0, expected="a rate in [0, 1)")
