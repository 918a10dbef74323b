"""A release as Hugging Face ``datasets`` reads it, offline: every split, the class labels,
streaming and a shard read alone (the Parquet shards and the card's YAML header together)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from fixtures.environment import require_package
from fixtures.releases import CATEGORIES
from fixtures.stores import N_POINTS, N_VIEWS


def test_datasets_loads_the_release_offline_with_splits_and_shapes(mini_release, tmp_path: Path,
                                                                   monkeypatch) -> None:
    require_package("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    import datasets

    loaded = datasets.load_dataset(str(mini_release.path), cache_dir=str(tmp_path / "cache"))
    assert list(loaded) == ["train", "validation", "test"]
    from vptoolkit.data import open_dataset

    with open_dataset(mini_release.path) as reference:
        for split, rows in loaded.items():
            assert rows.num_rows == len(reference.split(split))
            first = rows.with_format("numpy")[0]
            expected = reference.split(split)[0]
            assert first["name"] == expected["name"] and first["split"] == split
            assert first["points"].shape == (N_POINTS, 3) and first["points"].dtype == np.float32
            assert first["quality"].shape == (N_VIEWS, 4)
            np.testing.assert_array_equal(first["quality"], expected["quality"])
            np.testing.assert_array_equal(first["best_index"], expected["best_index"])
    views = datasets.load_dataset(str(mini_release.path), "views",
                                  cache_dir=str(tmp_path / "cache"))
    directions = np.array(views["train"].to_dict()["direction"])  # float64 as stored
    with open_dataset(mini_release.path) as reference:
        np.testing.assert_array_equal(directions, reference.views)


def test_class_labels_are_one_sorted_map_in_stores_card_croissant_and_datasets(
        mini_release, tmp_path: Path, monkeypatch) -> None:
    require_package("datasets")
    import datasets
    import yaml

    from vptoolkit.data import open_dataset
    from vptoolkit.dataset.store.reader import open_store

    expected = sorted(CATEGORIES)
    for store in (sorted(mini_release.path.glob("*.h5"))
                  + sorted(mini_release.path.glob("*.zarr.zip"))):
        with open_store(store) as reader:
            assert reader.attrs["class_names"] == expected, store.name
            categories = reader.array("categories")[...].tolist()
            labels = reader.array("labels")[...].tolist()
            assert labels == [expected.index(c if isinstance(c, str) else c.decode())
                              for c in categories], store.name
    card = mini_release.card.read_text(encoding="utf-8")
    header = yaml.safe_load(card.split("---\n")[1])
    default = next(c for c in header["dataset_info"] if c["config_name"] == "default")
    label = next(f for f in default["features"] if f["name"] == "label")
    assert label["dtype"]["class_label"]["names"] == {str(i): n for i, n in enumerate(expected)}
    assert "| 0 | `airplane` |" in card and "| 1 | `chair` |" in card
    document = json.loads(mini_release.croissant.read_text(encoding="utf-8"))
    categories_set = next(r for r in document["recordSet"] if r["@id"] == "categories")
    assert [(row["categories/label"], row["categories/category"])
            for row in categories_set["data"]] == list(enumerate(expected))
    models = next(r for r in document["recordSet"] if r["@id"] == "models")
    label_field = next(f for f in models["field"] if f["name"] == "label")
    assert label_field["references"] == {"field": {"@id": "categories/label"}}

    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    loaded = datasets.load_dataset(str(mini_release.path), cache_dir=str(tmp_path / "cache"))
    feature = loaded["train"].features["label"]
    assert isinstance(feature, datasets.ClassLabel) and feature.names == expected
    with open_dataset(mini_release.path) as reference:
        assert reference.class_names == expected
        for split, rows in loaded.items():
            assert rows["label"] == reference.split(split).labels.tolist()
            assert [feature.int2str(v) for v in rows["label"]] == rows["category"]


def test_datasets_streams_the_release(mini_release, monkeypatch) -> None:
    require_package("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    import datasets

    stream = datasets.load_dataset(str(mini_release.path), split="validation", streaming=True)
    first = next(iter(stream))
    assert first["split"] == "validation" and np.asarray(first["normals"]).shape == (N_POINTS, 3)


def test_a_shard_read_alone_by_datasets_has_the_cards_features(mini_release, tmp_path: Path,
                                                               monkeypatch) -> None:
    require_package("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    import datasets
    import pyarrow.parquet as pq
    import yaml

    from vptoolkit.data import open_dataset

    header = yaml.safe_load(mini_release.card.read_text(encoding="utf-8").split("---\n")[1])
    declared = {c["config_name"]: datasets.Features._from_yaml_list(c["features"])
                for c in header["dataset_info"]}
    for shard in mini_release.parquet:
        config = "views" if shard.parent.name == "views" else "default"
        metadata = json.loads(pq.read_schema(shard).metadata[b"huggingface"])
        assert datasets.Features.from_dict(metadata["info"]["features"]) == declared[config]
        alone = datasets.load_dataset("parquet", data_files=str(shard),
                                      cache_dir=str(tmp_path / "cache"))["train"]
        # datasets takes an Array2D from the metadata only for its Arrow extension type,
        # which plain lists are not: read alone, arrays are lists of lists of the same values.
        as_read = {name: (datasets.List(datasets.List(datasets.Value(feature.dtype)))
                          if isinstance(feature, datasets.Array2D) else feature)
                   for name, feature in declared[config].items()}
        assert alone.features == datasets.Features(as_read), shard.name
    train = mini_release.path / "data" / "train-00000-of-00001.parquet"
    alone = datasets.load_dataset("parquet", data_files=str(train),
                                  cache_dir=str(tmp_path / "cache"))["train"]
    label = alone.features["label"]
    assert isinstance(label, datasets.ClassLabel) and label.names == sorted(CATEGORIES)
    with open_dataset(mini_release.path) as reference:
        models = reference.split("train")
        assert alone["label"] == models.labels.tolist()
        assert [label.int2str(v) for v in alone["label"]] == alone["category"]
        np.testing.assert_array_equal(alone.with_format("numpy")[0]["quality"],
                                      models[0]["quality"])
