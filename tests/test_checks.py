"""Shared argument checks: the one output-suffix check every writer uses."""

from __future__ import annotations

from pathlib import Path

import pytest

from vptoolkit.checks import changed_values, check_keys, check_suffix
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
