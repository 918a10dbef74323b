"""Shared argument checks: the one output-suffix check every writer uses."""

from __future__ import annotations

from pathlib import Path

import pytest

from vptoolkit.checks import check_suffix
from vptoolkit.errors import InputError


def test_check_suffix_accepts_any_case_and_names_the_file(tmp_path):
    assert check_suffix(tmp_path / "a.NPZ", ".npz") == tmp_path / "a.NPZ"
    assert isinstance(check_suffix("b.png", ".png"), Path)
    with pytest.raises(InputError, match=r"^out.txt: output must end in \.npz$"):
        check_suffix(tmp_path / "out.txt", ".npz")
    with pytest.raises(InputError, match=r"^x: predictions must end in \.npz$"):
        check_suffix("x", ".npz", what="predictions")
