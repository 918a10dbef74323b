"""Old import paths of moved modules keep working, each with a DeprecationWarning naming the new one."""

from __future__ import annotations

import importlib

import pytest

MOVED = [
    ("vptoolkit.dataset.build", "build_dataset", "vptoolkit.dataset.build.run"),
    ("vptoolkit.dataset.build_options", "BuildOptions", "vptoolkit.dataset.build.options"),
    ("vptoolkit.dataset.plan", "plan_build", "vptoolkit.dataset.build.plan"),
    ("vptoolkit.dataset.release", "pack_release", "vptoolkit.dataset.release.pack"),
    ("vptoolkit.dataset.release_options", "ReleaseOptions", "vptoolkit.dataset.release.options"),
    ("vptoolkit.dataset.authors", "import_authors", "vptoolkit.dataset.authors.importer"),
    ("vptoolkit.dataset.authors_check", "check_measures", "vptoolkit.dataset.authors.check"),
    ("vptoolkit.dataset.split_files", "read_split_file", "vptoolkit.dataset.build.split_files"),
]


@pytest.mark.parametrize(("old", "name", "new"), MOVED)
def test_a_documented_old_path_warns_and_gives_the_moved_name(old: str, name: str,
                                                                new: str) -> None:
    moved = getattr(importlib.import_module(new), name)
    with pytest.warns(DeprecationWarning, match=rf"{old}\.{name} moved to {new}\.{name}"):
        assert getattr(importlib.import_module(old), name) is moved


def test_a_name_the_new_module_does_not_export_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        importlib.import_module("vptoolkit.dataset.plan").nothing_here  # noqa: B018
