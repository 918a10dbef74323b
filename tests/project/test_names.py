"""Model names and categories become paths: the one rule, where stores are written and read."""

from __future__ import annotations

from pathlib import Path

import pytest

from fixtures.stores import MODELS, synthetic_entries, write_synthetic
from vptoolkit.dataset.store import writer
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.errors import InputError
from vptoolkit.files import check_path_part
from vptoolkit.sphere import fibonacci_sphere

pytest.importorskip("zarr")

GOOD = ["chair", "chair_0001", "a..b", "chaise-longue ü", "名前", "x.obj"]
BAD = {
    "empty": ("", "non-empty string"),
    "dot": (".", "starts with '.'"),
    "dot-dot": ("..", "starts with '.'"),
    "hidden": (".hidden", "starts with '.'"),
    "up": ("../escaped", "path separator"),
    "inner": ("a/../b", "path separator"),
    "absolute": ("/tmp/escaped", "path separator"),
    "backslash": ("a\\b", "path separator"),
    "drive": ("C:escaped", "drive"),
    "nul": ("a\x00b", "control character"),
    "newline": ("a\nb", "control character"),
    "delete": ("a\x7f", "control character"),
    "c1": ("a\x85", "control character"),
    "not-a-string": (3, "non-empty string"),
}


@pytest.mark.parametrize("name", GOOD)
def test_a_plain_name_passes_unchanged(name: str) -> None:
    assert check_path_part(name, "category") == name


@pytest.mark.parametrize("case", list(BAD))
def test_a_name_that_is_not_one_path_part_is_refused_in_one_line(case: str) -> None:
    value, problem = BAD[case]
    with pytest.raises(InputError, match=problem) as caught:
        check_path_part(value, "dataset.zarr: category")
    message = str(caught.value)
    assert message.startswith("dataset.zarr: category") and "\n" not in message


def hostile_entries(field: str, value: str, *, n_views: int = 50) -> list:
    """The synthetic entries with every model's ``field`` (name or category) set to ``value``."""
    import dataclasses

    entries = synthetic_entries(n_views=n_views)
    if field == "category":
        return [dataclasses.replace(entry, category=value) for entry in entries]
    return [dataclasses.replace(entries[0], name=value)]


@pytest.mark.parametrize("kind", ["dataset.zarr", "dataset.h5"])
@pytest.mark.parametrize(("field", "value"), [("category", "../../escaped"),
                                              ("category", "/tmp/escaped"),
                                              ("name", "..\\escaped")])
def test_the_writer_refuses_a_bad_name_naming_the_store(tmp_path: Path, kind: str, field: str,
                                                        value: str) -> None:
    with pytest.raises(InputError) as caught:
        write_synthetic(tmp_path / kind, hostile_entries(field, value))
    message = str(caught.value)
    assert str(tmp_path / kind) in message and repr(value) in message and "\n" not in message
    assert list(tmp_path.iterdir()) == []


@pytest.fixture()
def old_store(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A store with the category ``../../escaped``, as a writer without the rule made it,
    with the authors' 1000 views so that export-authors would take it."""
    (tmp_path / "old").mkdir()
    with monkeypatch.context() as patch:
        patch.setattr(writer, "check_path_part", lambda value, what: value)
        return write_synthetic(tmp_path / "old" / "dataset.zarr",
                               hostile_entries("category", "../../escaped", n_views=1000),
                               views=fibonacci_sphere(1000))


def _made_outside(tmp_path: Path) -> list[str]:
    return sorted(p.name for p in tmp_path.iterdir() if p.name not in ("old", "deep"))


def test_the_reader_refuses_a_store_written_before_the_rule(old_store: Path) -> None:
    with open_store(old_store) as reader, pytest.raises(InputError) as caught:
        reader.models()
    assert str(caught.value) == (
        f"dataset.zarr: model {MODELS[0][1]!r}, category '../../escaped' cannot name a file or "
        "folder (it holds a path separator)")


def test_loading_and_exporting_a_hostile_store_write_nothing(old_store: Path,
                                                             tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main
    from vptoolkit.data import open_dataset

    with pytest.raises(InputError, match="category '../../escaped' cannot name"):
        open_dataset(old_store)
    (tmp_path / "deep" / "er").mkdir(parents=True)
    result = CliRunner().invoke(main, ["export-authors", str(old_store),
                                       str(tmp_path / "deep" / "er" / "out")])
    assert result.exit_code == 2 and result.stderr.count("\n") == 1, result.output
    assert "dataset.zarr: model" in result.stderr and "'../../escaped'" in result.stderr
    assert list((tmp_path / "deep" / "er").iterdir()) == [] and _made_outside(tmp_path) == []
