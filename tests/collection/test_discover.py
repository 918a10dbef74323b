"""Discovering a collection: folders, globs and list files, streamed and keyed by relative path."""

from __future__ import annotations

import itertools
import tracemalloc
from pathlib import Path

import pytest

from vptoolkit.collection.discover import Entry, discover
from vptoolkit.errors import InputError


@pytest.fixture()
def tree(tmp_path: Path) -> Path:
    root = tmp_path / "coll"
    for name in ("a/teapot.stl", "b/teapot.stl", "b/deep/scan.PLY", "cloud.xyz", "z.off",
                 ".hidden/x.off", "b/.partial.off", "notes.txt"):
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_bytes(b"")
    return root


def test_a_folder_is_walked_sorted_and_keyed_by_relative_path(tree: Path) -> None:
    keys = [entry.key for entry in discover(tree)]
    assert keys == ["a/teapot.stl", "b/deep/scan.PLY", "b/teapot.stl", "cloud.xyz", "z.off"]
    assert Entry(str(tree / "a" / "teapot.stl"), "a/teapot.stl") in discover(tree)


def test_a_glob_keeps_the_matching_files_keyed_below_its_fixed_part(tree: Path) -> None:
    assert [e.key for e in discover(f"{tree}/**/*.stl")] == ["a/teapot.stl", "b/teapot.stl"]
    assert [e.key for e in discover(f"{tree}/b/*")] == ["teapot.stl"]
    assert [e.key for e in discover(f"{tree}/*.o?f")] == ["z.off"]


def test_a_list_file_names_paths_relative_to_itself_and_urls(tree: Path) -> None:
    listing = tree / "models.txt"
    listing.write_text("# models\na/teapot.stl\n\nhttps://example.org/m.off\nb/teapot.stl\n")
    entries = list(discover(f"@{listing}"))
    assert [e.key for e in entries] == ["a/teapot.stl", "https://example.org/m.off",
                                        "b/teapot.stl"]
    assert entries[0].path == str(tree / "a" / "teapot.stl")


def test_missing_sources_are_one_line_input_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no such folder"):
        list(discover(tmp_path / "missing"))
    with pytest.raises(InputError, match="no such list file"):
        list(discover(f"@{tmp_path / 'missing.txt'}"))
    (tmp_path / "notes.txt").write_bytes(b"")
    with pytest.raises(InputError, match="not a model file; give a model file, a folder"):
        list(discover(tmp_path / "notes.txt"))


def test_one_model_file_is_the_entry_of_its_name(tree: Path) -> None:
    assert list(discover(tree / "a" / "teapot.stl")) == [
        Entry(str(tree / "a" / "teapot.stl"), "teapot.stl")]


def test_a_list_of_200000_lines_is_read_with_flat_memory(tree: Path) -> None:
    listing = tree / "long.txt"
    with listing.open("w") as stream:
        for number in range(200_000):
            stream.write(("a/teapot.stl", "b/teapot.stl", "z.off")[number % 3] + "\n")
    entries = discover(f"@{listing}")
    list(itertools.islice(entries, 1000))  # warm up
    tracemalloc.start()
    try:
        count = 1000 + sum(1 for _ in entries)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert count == 200_000
    assert peak < 1_000_000  # bytes: a few lines at a time, not the list
