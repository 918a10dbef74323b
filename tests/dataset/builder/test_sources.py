"""A build's sources: model discovery in a ModelNet tree or a flat folder, and split assignment."""

from __future__ import annotations

import hashlib
import shutil

import pytest

from fixtures.builds import make_tree
from fixtures.paths import MALFORMED
from vptoolkit.conventions import model_name
from vptoolkit.dataset.builder.sources import (
    assign_split,
    discover_models,
    split_duplicates,
)
from vptoolkit.errors import InputError
from vptoolkit.samples import sample_path


def test_discover_models_reads_a_modelnet_tree_and_a_flat_folder(tmp_path):
    root = make_tree(tmp_path / "meshes", {
        "chair/train/chair_0001.off": sample_path("ballA"),
        "chair/test/chair_0002.off": sample_path("ballA"),
        "loose/bunny.ply": sample_path("bunny"),
        "top.stl": sample_path("teapot"),
        ".hidden/secret.obj": sample_path("table"),
        "chair/train/.partial.off": sample_path("ballA"),
        "chair/README.md": MALFORMED / "README.md",
    })
    models = discover_models(root)
    assert [(m.category, m.name, m.folder_split, m.source) for m in models] == [
        ("chair", "chair__test__chair_0002", "test", "chair/test/chair_0002.off"),
        ("chair", "chair__train__chair_0001", "train", "chair/train/chair_0001.off"),
        ("loose", "loose__bunny", None, "loose/bunny.ply"),
        ("meshes", "top", None, "top.stl"),
    ]
    assert all(m.path.is_absolute() and m.path.is_file() for m in models)
    assert models[1].model_id == "chair/chair__train__chair_0001"
    assert [m.name for m in discover_models(root, ["loose", "meshes"])] == ["loose__bunny", "top"]


def test_a_name_is_the_path_under_the_source_without_its_suffix():
    assert model_name("teapot.stl") == "teapot"
    assert model_name("a/teapot.stl") == "a__teapot"
    assert model_name("chair/train/chair_0001.off") == "chair__train__chair_0001"
    assert model_name("a/b.tar.obj") == "a__b.tar"


def test_equal_stems_in_two_folders_are_two_models_of_their_folders(tmp_path):
    root = make_tree(tmp_path / "src", {"a/teapot.stl": sample_path("teapot"),
                                        "b/teapot.stl": sample_path("teapot")})
    models = discover_models(root)
    assert [(m.category, m.name) for m in models] == [("a", "a__teapot"), ("b", "b__teapot")]
    unique, failures = split_duplicates(models)
    assert unique == models and failures == []


def test_discover_models_rejects_bad_sources(tmp_path):
    (tmp_path / "empty").mkdir()
    (tmp_path / "notes").mkdir()
    shutil.copyfile(MALFORMED / "README.md", tmp_path / "notes" / "README.md")
    with pytest.raises(InputError, match="does not exist"):
        discover_models(tmp_path / "missing")
    with pytest.raises(InputError, match="not a folder"):
        discover_models(tmp_path / "notes" / "README.md")
    for folder in ("empty", "notes"):
        with pytest.raises(InputError, match="no mesh files found"):
            discover_models(tmp_path / folder)
    make_tree(tmp_path / "tree", {"cup/a.obj": sample_path("table")})
    with pytest.raises(InputError, match="categories: no mesh files in plate"):
        discover_models(tmp_path / "tree", ["cup", "plate"])
    with pytest.raises(InputError, match="categories: expected a list"):
        discover_models(tmp_path / "tree", "cup")  # type: ignore[arg-type]


def test_assign_split_follows_the_schema_formula():
    def by_hand(seed: int, model_id: str) -> str:
        u = int(hashlib.sha256(f"{seed}:{model_id}".encode()).hexdigest()[:16], 16) / 2**64
        return "train" if u < 0.8 else "val" if u < 0.9 else "test"

    names = [f"chair_{i:04d}" for i in range(3000)]
    splits = [assign_split("chair", name, seed=7) for name in names]
    assert splits == [by_hand(7, f"chair/{name}") for name in names]
    fractions = {split: splits.count(split) / len(splits) for split in ("train", "val", "test")}
    assert fractions == pytest.approx({"train": 0.8, "val": 0.1, "test": 0.1}, abs=0.03)
    assert splits != [assign_split("chair", name, seed=8) for name in names]


def test_assign_split_keeps_modelnet_test_and_draws_val_from_train():
    names = [f"desk_{i:04d}" for i in range(3000)]
    assert {assign_split("desk", n, seed=0, folder_split="test") for n in names} == {"test"}
    from_train = [assign_split("desk", n, seed=0, folder_split="train") for n in names]
    assert set(from_train) == {"train", "val"}
    assert from_train.count("val") / len(names) == pytest.approx(1 / 9, abs=0.02)
    # a model the free split sends to val or test goes to val from train/, and stays train otherwise
    for name, split in zip(names, from_train):
        free = assign_split("desk", name, seed=0)
        assert split == ("train" if free == "train" else split)
    with pytest.raises(InputError, match="folder_split"):
        assign_split("desk", "desk_0001", seed=0, folder_split="val")
    with pytest.raises(InputError, match="seed"):
        assign_split("desk", "desk_0001", seed="0")  # type: ignore[arg-type]
