"""Shared argument checks: the one output-suffix check every writer uses."""

from __future__ import annotations

from pathlib import Path

import pytest

from vptoolkit.checks import check_keys, check_suffix
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
