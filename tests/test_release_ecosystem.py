"""A release as the ML-datasets ecosystem sees it: Parquet for datasets, Croissant for
mlcroissant, reproducible bytes, per-mesh provenance, and verify's integrity rows."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.releases import CATEGORIES, forge_shard, write_release_build
from fixtures.stores import N_POINTS, N_VIEWS
from vptoolkit.dataset.release.options import ReleaseOptions
from vptoolkit.dataset.store.schema import ARRAY_NAMES
from vptoolkit.errors import InputError, MissingDependencyError, VerificationError

CREATED = "2026-03-04T05:06:07Z"
N_MODELS = sum(CATEGORIES.values())


def _write_build(folder: Path, **options: Any) -> Path:
    """A build folder with the synthetic models (``write_release_build``'s options)."""
    require_package("pyarrow")
    return write_release_build(folder, **options)


@pytest.fixture(scope="module")
def licenses_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("licences") / "licenses.csv"
    rows = ["name,license,author,url",
            'airplane_0000,cc-by-4.0,"Ada, L.",https://example.org/a0',
            "chair_0001,mit,Bob,https://example.org/c1"]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def release(tmp_path_factory: pytest.TempPathFactory, licenses_csv: Path):
    from vptoolkit.dataset.release.pack import pack_release
    from vptoolkit.dataset.release.options import FORMATS

    base = tmp_path_factory.mktemp("eco")
    build = _write_build(base / "build")
    options = ReleaseOptions(formats=FORMATS, created=CREATED, version="2.1.0", name="mini",
                             pretty_name="Mini viewpoints", licenses=licenses_csv,
                             source_url="https://example.org/src", creator="Tester")
    return pack_release(build, base / "release", options)


@pytest.fixture()
def release_copy(release, tmp_path: Path) -> Path:
    return Path(shutil.copytree(release.path, tmp_path / "release"))


# --------------------------------------------------------------------------- Hugging Face


def test_datasets_loads_the_release_offline_with_splits_and_shapes(release, tmp_path: Path,
                                                                   monkeypatch) -> None:
    require_package("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    import datasets

    loaded = datasets.load_dataset(str(release.path), cache_dir=str(tmp_path / "cache"))
    assert list(loaded) == ["train", "validation", "test"]
    from vptoolkit.data import open_dataset

    with open_dataset(release.path) as reference:
        for split, rows in loaded.items():
            assert rows.num_rows == len(reference.split(split))
            first = rows.with_format("numpy")[0]
            expected = reference.split(split)[0]
            assert first["name"] == expected["name"] and first["split"] == split
            assert first["points"].shape == (N_POINTS, 3) and first["points"].dtype == np.float32
            assert first["quality"].shape == (N_VIEWS, 4)
            np.testing.assert_array_equal(first["quality"], expected["quality"])
            np.testing.assert_array_equal(first["best_index"], expected["best_index"])
    views = datasets.load_dataset(str(release.path), "views", cache_dir=str(tmp_path / "cache"))
    directions = np.array(views["train"].to_dict()["direction"])  # float64 as stored
    with open_dataset(release.path) as reference:
        np.testing.assert_array_equal(directions, reference.views)


def test_class_labels_are_one_sorted_map_in_stores_card_croissant_and_datasets(
        release, tmp_path: Path, monkeypatch) -> None:
    require_package("datasets")
    import datasets
    import yaml

    from vptoolkit.data import open_dataset
    from vptoolkit.dataset.store.reader import open_store

    expected = sorted(CATEGORIES)
    for store in sorted(release.path.glob("*.h5")) + sorted(release.path.glob("*.zarr.zip")):
        with open_store(store) as reader:
            assert reader.attrs["class_names"] == expected, store.name
            categories = reader.array("categories")[...].tolist()
            labels = reader.array("labels")[...].tolist()
            assert labels == [expected.index(c if isinstance(c, str) else c.decode())
                              for c in categories], store.name
    card = release.card.read_text(encoding="utf-8")
    header = yaml.safe_load(card.split("---\n")[1])
    default = next(c for c in header["dataset_info"] if c["config_name"] == "default")
    label = next(f for f in default["features"] if f["name"] == "label")
    assert label["dtype"]["class_label"]["names"] == {str(i): n for i, n in enumerate(expected)}
    assert "| 0 | `airplane` |" in card and "| 1 | `chair` |" in card
    document = json.loads(release.croissant.read_text(encoding="utf-8"))
    categories_set = next(r for r in document["recordSet"] if r["@id"] == "categories")
    assert [(row["categories/label"], row["categories/category"])
            for row in categories_set["data"]] == list(enumerate(expected))
    models = next(r for r in document["recordSet"] if r["@id"] == "models")
    label_field = next(f for f in models["field"] if f["name"] == "label")
    assert label_field["references"] == {"field": {"@id": "categories/label"}}

    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    loaded = datasets.load_dataset(str(release.path), cache_dir=str(tmp_path / "cache"))
    feature = loaded["train"].features["label"]
    assert isinstance(feature, datasets.ClassLabel) and feature.names == expected
    with open_dataset(release.path) as reference:
        assert reference.class_names == expected
        for split, rows in loaded.items():
            assert rows["label"] == reference.split(split).labels.tolist()
            assert [feature.int2str(v) for v in rows["label"]] == rows["category"]


def test_datasets_streams_the_release(release, monkeypatch) -> None:
    require_package("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    import datasets

    stream = datasets.load_dataset(str(release.path), split="validation", streaming=True)
    first = next(iter(stream))
    assert first["split"] == "validation" and np.asarray(first["normals"]).shape == (N_POINTS, 3)


def test_card_dataset_info_has_features_and_sizes(release) -> None:
    require_package("datasets")
    import yaml
    from datasets import DatasetInfo, Features

    card = release.card.read_text(encoding="utf-8")
    header = yaml.safe_load(card.split("---\n")[1])
    default = next(c for c in header["dataset_info"] if c["config_name"] == "default")
    features = Features._from_yaml_list(default["features"])
    assert features["points"].shape == (N_POINTS, 3) and features["points"].dtype == "float32"
    assert features["mesh_faces"].shape == (None, 3)
    assert all(split["num_bytes"] > 0 for split in default["splits"])
    assert sum(split["num_examples"] for split in default["splits"]) == N_MODELS
    DatasetInfo._from_yaml_dict(default)  # the hub's own parser accepts it
    assert header["license_name"] and header["license_link"] == "LICENSES.csv"
    assert header["pretty_name"] == "Mini viewpoints"


def test_a_shard_read_alone_by_datasets_has_the_cards_features(release, tmp_path: Path,
                                                               monkeypatch) -> None:
    require_package("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    import datasets
    import pyarrow.parquet as pq
    import yaml

    from vptoolkit.data import open_dataset

    header = yaml.safe_load(release.card.read_text(encoding="utf-8").split("---\n")[1])
    declared = {c["config_name"]: datasets.Features._from_yaml_list(c["features"])
                for c in header["dataset_info"]}
    for shard in release.parquet:
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
    train = release.path / "data" / "train-00000-of-00001.parquet"
    alone = datasets.load_dataset("parquet", data_files=str(train),
                                  cache_dir=str(tmp_path / "cache"))["train"]
    label = alone.features["label"]
    assert isinstance(label, datasets.ClassLabel) and label.names == sorted(CATEGORIES)
    with open_dataset(release.path) as reference:
        models = reference.split("train")
        assert alone["label"] == models.labels.tolist()
        assert [label.int2str(v) for v in alone["label"]] == alone["category"]
        np.testing.assert_array_equal(alone.with_format("numpy")[0]["quality"],
                                      models[0]["quality"])


def test_parquet_shards_repeat_byte_for_byte_with_sorted_json_features(release,
                                                                       tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    from vptoolkit.dataset.release.parquet import write_parquet_shards
    from vptoolkit.dataset.store.reader import open_store

    with open_store(next(release.path.glob("*.h5"))) as reader:
        first = write_parquet_shards(reader, tmp_path / "a")
        second = write_parquet_shards(reader, tmp_path / "b")
    assert [s.path for s in first] == [s.path for s in second]
    for shard in first:
        written = (tmp_path / "a" / shard.path).read_bytes()
        assert written == (tmp_path / "b" / shard.path).read_bytes(), shard.path
        assert written == (release.path / shard.path).read_bytes(), shard.path
        text = pq.read_schema(tmp_path / "a" / shard.path).metadata[b"huggingface"].decode()
        assert text == json.dumps(json.loads(text), sort_keys=True)


# --------------------------------------------------------------------------- Croissant


@pytest.fixture(scope="module")
def sharded(tmp_path_factory: pytest.TempPathFactory):
    """The release cut into Parquet shards of at most 30 kB of rows (several per split)."""
    from vptoolkit.dataset.release.pack import pack_release

    base = tmp_path_factory.mktemp("sharded")
    return pack_release(_write_build(base / "build"), base / "release",
                        ReleaseOptions(created=CREATED, shard_size="30KB"))


def test_a_small_shard_size_gives_several_hub_named_shards_that_datasets_loads(
        sharded, tmp_path: Path, monkeypatch) -> None:
    require_package("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    import datasets

    train = sorted(p.name for p in (sharded.path / "data").glob("train-*.parquet"))
    assert len(train) >= 2
    assert train == [f"train-{i:05d}-of-{len(train):05d}.parquet" for i in range(len(train))]
    import pyarrow.parquet as pq

    for shard in sharded.parquet:  # the rows' Arrow size is bounded, as the hub measures it
        assert pq.read_table(shard).nbytes <= 30_000
        assert shard.stat().st_size <= 30_000 + pq.ParquetFile(shard).metadata.serialized_size
    card = sharded.card.read_text(encoding="utf-8")
    for name in train:
        assert f"    - data/{name}\n" in card  # the configs list every shard
    loaded = datasets.load_dataset(str(sharded.path), cache_dir=str(tmp_path / "cache"))
    from vptoolkit.data import open_dataset

    with open_dataset(sharded.path) as reference:
        for split, rows in loaded.items():
            assert rows["name"] == reference.split(split).names  # every shard, in store order
            assert rows["label"] == reference.split(split).labels.tolist()
        first = loaded["train"].with_format("numpy")[len(loaded["train"]) - 1]
        np.testing.assert_array_equal(first["quality"], reference.split("train")[-1]["quality"])


def test_verify_compares_every_shard_of_a_split(sharded, tmp_path: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    assert verify(sharded.path).ok
    copy = Path(shutil.copytree(sharded.path, tmp_path / "release"))
    second = "data/train-00001-of-" + next(
        (copy / "data").glob("train-00001-of-*.parquet")).name.rsplit("-of-", 1)[1]
    name = forge_shard(copy, second, "quality")
    forge_shard(copy, second, "label")  # compared with the store's labels array
    report = verify(copy)
    assert [p.target for p in report.problems] == [f"{second}:{name}:label",
                                                   f"{second}:{name}:quality"]


@pytest.mark.parametrize(("text", "expected"), [("200KB", 200_000), ("500MB", 500_000_000),
                                                ("1.5GB", 1_500_000_000), ("64MiB", 64 << 20),
                                                ("4096", 4096), (" 2 kb ", 2000)])
def test_shard_sizes_read_as_bytes(text: str, expected: int) -> None:
    from vptoolkit.dataset.release.parquet import parse_size

    assert parse_size(text) == expected


def test_a_bad_shard_size_is_one_line_and_exit_2(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    build = _write_build(tmp_path / "build")
    for bad in ("lots", "0KB", "5 parsecs"):
        result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release"),
                                           "--shard-size", bad])
        assert result.exit_code == 2, result.output
        assert result.output.startswith("vptool: error: --shard-size: ")
        assert not (tmp_path / "release").exists()


# rdflib and pandas, under mlcroissant, warn about their own APIs; not ours.
@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:ConjunctiveGraph is deprecated:DeprecationWarning")
@pytest.mark.filterwarnings("ignore:The inplace keyword in DataFrame.reset_index")
def test_mlcroissant_validates_and_loads_a_record_of_each_record_set(release) -> None:
    require_package("mlcroissant")
    croissant = release.path / "croissant.json"
    checked = subprocess.run(
        [sys.executable, "-m", "mlcroissant.scripts.validate", "--jsonld", str(croissant)],
        capture_output=True, text=True, cwd=release.path,
    )  # what `mlcroissant validate --jsonld croissant.json` runs
    assert checked.returncode == 0, checked.stderr[-2000:]
    assert "Done." in checked.stderr
    logged = re.findall(r"^([EW])\d{4} .*$", checked.stderr, re.MULTILINE)
    assert logged == [], checked.stderr[-2000:]  # no error and no warning
    import mlcroissant

    dataset = mlcroissant.Dataset(jsonld=str(croissant))
    model = next(iter(dataset.records(record_set="models")))
    assert np.asarray(model["models/points"]).shape == (N_POINTS, 3)
    assert np.asarray(model["models/quality"]).shape == (N_VIEWS, 4)
    assert model["models/split"] in (b"train", b"validation", b"test")
    view = next(iter(dataset.records(record_set="views")))
    assert np.asarray(view["views/direction"]).shape == (3,)


def test_croissant_carries_version_dates_creator_and_rai(release) -> None:
    document = json.loads(release.croissant.read_text(encoding="utf-8"))
    assert document["version"] == "2.1.0"
    assert document["datePublished"] == CREATED
    assert document["url"] == "https://example.org/src"
    assert document["creator"]["name"] == "Tester"
    card = release.card.read_text(encoding="utf-8")
    for key in ("rai:dataCollection", "rai:dataPreprocessingProtocol", "rai:dataUseCases",
                "rai:dataLimitations", "rai:personalSensitiveInformation",
                "rai:dataReleaseMaintenancePlan"):
        assert document[key], key
    assert "geometric proxies" in document["rai:dataLimitations"]
    assert "geometric proxies" in card


# --------------------------------------------------------------------------- versions, provenance


def test_version_goes_into_attributes_card_and_croissant_not_names(release) -> None:
    from vptoolkit.dataset.store.reader import open_store

    assert release.zarr_zip.name == "mini.zarr.zip" and release.hdf5.name == "mini.h5"
    assert not [name for name in release.files if "2.1.0" in name]
    with open_store(release.hdf5) as reader:
        assert reader.attrs["dataset_version"] == "2.1.0"
        assert reader.attrs["created"] == CREATED
    card = release.card.read_text(encoding="utf-8")
    assert f"Version\n2.1.0, released {CREATED}" in card


def test_provenance_is_stored_per_model_tabled_and_shipped(release) -> None:
    from vptoolkit.data import open_dataset

    with open_dataset(release.path) as dataset:
        assert dataset.record("airplane_0000")["provenance"] == {
            "license": "cc-by-4.0", "author": "Ada, L.", "url": "https://example.org/a0"}
        assert "provenance" not in dataset.record("airplane_0001")
    card = release.card.read_text(encoding="utf-8")
    assert "| `chair_0001` | mit | Bob | https://example.org/c1 |" in card
    shipped = (release.path / "LICENSES.csv").read_text(encoding="utf-8").splitlines()
    assert shipped[0] == "name,license,author,url" and len(shipped) == 1 + N_MODELS
    assert 'airplane_0000,cc-by-4.0,"Ada, L.",https://example.org/a0' in shipped
    assert any("no row in the licence table" in line for line in release.warnings)
    require_package("pyarrow")
    import pyarrow.parquet as pq

    table = pq.read_table(release.path / "data" / "train-00000-of-00001.parquet")
    row = table.to_pylist()[0]
    assert row["name"] == "airplane_0000" and row["license"] == "cc-by-4.0"


def test_schema_ships_inside_the_release(release) -> None:
    schema = (release.path / "SCHEMA.md").read_text(encoding="utf-8")
    assert "models_json" in schema
    assert "SCHEMA.md" in release.files


@pytest.mark.parametrize("bad, message", [
    ({"version": "1.0"}, "version: '1.0' is not MAJOR.MINOR.PATCH"),
    ({"created": "yesterday"}, "created: 'yesterday' is not an ISO 8601 time"),
    ({"formats": ["parquet", "csv"]}, "formats: expected one or more of"),
], ids=["version", "created", "formats"])
def test_bad_release_options_are_input_errors(tmp_path: Path, bad: dict, message: str) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    build = _write_build(tmp_path / "build")
    with pytest.raises(InputError, match=re.escape(message)):
        pack_release(build, tmp_path / "release", ReleaseOptions(**bad))
    assert not (tmp_path / "release").exists()


@pytest.mark.parametrize("bad, message", [
    ({"name": "../up"}, "name: '../up' must start with a letter or digit"),
    ({"license": "my own"}, "license: 'my own' is not an SPDX licence identifier"),
    ({"formats": "parquet"}, "formats: expected a sequence of format names"),
    ({"formats": []}, "formats: expected one or more of parquet, zarr, hdf5, got none"),
    ({"shard_size": "big"}, "shard_size:"),
    ({"licenses": {"chair_0001": {"license": "mine"}}}, "licenses: chair_0001: 'mine' is not"),
    ({"licenses": {"chair_0001": {"license": "MIT", "author": "Ada\x1b[2J"}}},
     "licenses: chair_0001: the author cell holds the control character U+001B; remove it"),
    ({"licenses": {"chair_0001": {"license": " "}}},
     "licenses: chair_0001 needs a name and a license"),
    ({"licenses": {"chair_0001": {"license": "MIT", "url": 7}}},
     "licenses: chair_0001: the url cell: expected text, got int"),
    ({"licenses": {"chair_0001": {"license": "MIT"}, " chair_0001": {"license": "MIT"}}},
     "licenses:  chair_0001 repeats the model 'chair_0001'"),
    ({"creator": 7}, "creator: expected text, got 7"),
], ids=["name", "license", "formats-text", "no-formats", "shard-size", "table", "table-control",
        "table-empty", "table-cell-type", "table-repeat", "creator"])
def test_release_options_are_checked_when_made(bad: dict, message: str) -> None:
    with pytest.raises(InputError, match=re.escape(message)):
        ReleaseOptions(**bad)


def test_a_licence_table_given_as_a_mapping_is_read_as_its_csv_file(tmp_path: Path) -> None:
    from vptoolkit.dataset.release.licenses import read_licenses

    table = tmp_path / "table.csv"
    table.write_text("name,license,author,url,note\n airplane_0000 , MIT , Ada ,,x\n",
                     encoding="utf-8")
    given = {" airplane_0000 ": {"license": " MIT ", "author": " Ada ", "url": "", "note": "x"}}
    assert ReleaseOptions(licenses=given).license_table() == read_licenses(table) == {
        "airplane_0000": {"license": "MIT", "author": "Ada"}}


def test_release_options_keep_their_checked_values() -> None:
    from vptoolkit.conventions import DATASET_VERSION
    from vptoolkit.dataset.release.parquet import DEFAULT_SHARD_BYTES
    from vptoolkit.dataset.release.options import DEFAULT_FORMATS, DEFAULT_LICENSE, DEFAULT_NAME

    default = ReleaseOptions()
    assert (default.name, default.license, default.formats, default.version) == (
        DEFAULT_NAME, DEFAULT_LICENSE, DEFAULT_FORMATS, DATASET_VERSION)
    assert default.shard_bytes == DEFAULT_SHARD_BYTES and default.created is None
    assert default.default_license is None and default.license_table() is None
    given = ReleaseOptions(license=" CC-BY-4.0 ", formats=("zarr", "zarr", "hdf5"),
                           shard_size="2KiB", created="2026-03-04T06:06:07+01:00",
                           licenses="table.csv")
    assert given.license == given.default_license == "CC-BY-4.0"
    assert given.formats == ("zarr", "hdf5") and given.shard_bytes == 2048
    assert given.created == "2026-03-04T05:06:07Z" and given.licenses == Path("table.csv")
    assert ReleaseOptions(created=given.created) == ReleaseOptions(created="2026-03-04T05:06:07")


def test_a_licence_table_without_its_columns_names_the_file(tmp_path: Path) -> None:
    from vptoolkit.dataset.release.licenses import read_licenses

    (tmp_path / "l.csv").write_text("name,licence\nx,mit\n", encoding="utf-8")
    with pytest.raises(InputError, match="l.csv: header lacks the column"):
        read_licenses(tmp_path / "l.csv")
    (tmp_path / "l.csv").write_text("name,license,author,url\nx,mit,,\nx,mit,,\n")
    with pytest.raises(InputError, match="l.csv: line 3 repeats the model 'x'"):
        read_licenses(tmp_path / "l.csv")


def test_an_empty_split_is_a_loud_warning(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    entries_split = {f"{c}_{i:04d}": "train" for c, n in CATEGORIES.items() for i in range(n)}
    build = _write_build(tmp_path / "build", splits=entries_split)
    result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release")])
    assert result.exit_code == 0, result.output
    assert "vptool: warning: split 'validation' is empty" in result.stderr
    assert "vptool: warning: split 'test' is empty" in result.stderr
    card = (tmp_path / "release" / "README.md").read_text(encoding="utf-8")
    assert "> **Warning.** split 'test' is empty" in card
    assert "data/test-" not in card  # no config for a split without rows


def test_parquet_only_release(tmp_path: Path) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    build = _write_build(tmp_path / "build")
    result = pack_release(build, tmp_path / "release", ReleaseOptions(formats=["parquet"]))
    assert result.zarr_zip is None and result.hdf5 is None
    names = sorted(p.name for p in result.path.iterdir())
    assert not [n for n in names if n.endswith((".h5", ".zip"))] and "data" in names
    assert not [p for p in result.path.rglob(".*")]  # the describing copy is gone



def test_hdf5_only_card_promises_no_datasets_loading(tmp_path: Path) -> None:
    import yaml

    from vptoolkit.dataset.release.pack import pack_release

    build = _write_build(tmp_path / "build")
    result = pack_release(build, tmp_path / "release", ReleaseOptions(formats=["hdf5"]))
    card = result.card.read_text(encoding="utf-8")
    header = yaml.safe_load(card.split("---\n")[1])
    assert "configs" not in header and "dataset_info" not in header
    body = card.split("---\n", 2)[2]
    assert "load_dataset" not in body and "Parquet shards hold" not in body
    assert f"`datasets` cannot load it; read `{result.hdf5.name}`" in body
    assert f'h5py.File("{result.hdf5.name}"' in body
    assert "zarr" not in body.split("## Counts")[0]  # no Zarr zip to name


def test_card_shows_zarr_reading_only_with_a_zarr_zip(release) -> None:
    body = release.card.read_text(encoding="utf-8").split("## Counts")[0]
    assert f'ZipStore("{release.zarr_zip.name}"' in body
    assert f'h5py.File("{release.hdf5.name}"' in body

# --------------------------------------------------------------------------- reproducibility


def test_two_independent_builds_pack_to_identical_sha256sums(tmp_path: Path,
                                                             monkeypatch) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    first = _write_build(tmp_path / "a" / "build", created="2025-01-01T00:00:00Z")
    second = _write_build(tmp_path / "b" / "build", created="2025-06-30T12:00:00Z")
    one = pack_release(first, tmp_path / "a" / "release", ReleaseOptions(created=CREATED))
    two = pack_release(second, tmp_path / "b" / "release", ReleaseOptions(created=CREATED))
    manifest = (one.path / "SHA256SUMS").read_text()
    assert manifest == (two.path / "SHA256SUMS").read_text()
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1772600767")  # 2026-03-04T05:06:07Z
    three = pack_release(second, tmp_path / "c" / "release")
    assert three.created == CREATED
    assert (three.path / "SHA256SUMS").read_text() == manifest


@pytest.mark.parametrize(("created", "epoch", "needle"), [
    ("9999-12-31T23:59:59-01:00", None, "created: '9999-12-31T23:59:59-01:00' is outside"),
    ("0001-01-01T00:00:00+01:00", None, "created: '0001-01-01T00:00:00+01:00' is outside"),
    (None, "99999999999999999999", "SOURCE_DATE_EPOCH: 99999999999999999999 seconds is beyond"),
    (None, "\u00b2", "SOURCE_DATE_EPOCH: '\u00b2' is not a whole number"),
    (None, "9" * 5000, "SOURCE_DATE_EPOCH: 999"),
], ids=["after-9999", "before-year-1", "huge-epoch", "superscript-two", "5000-digits"])
def test_release_times_beyond_the_calendar_are_one_line(monkeypatch, created, epoch,
                                                        needle) -> None:
    from vptoolkit.dataset.release.options import release_created

    if epoch is None:
        monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    else:
        monkeypatch.setenv("SOURCE_DATE_EPOCH", epoch)
    with pytest.raises(InputError, match=re.escape(needle)) as caught:
        release_created(created, None)
    assert "\n" not in str(caught.value) and len(str(caught.value)) < 300


def test_release_times_before_the_year_1000_keep_four_digits(monkeypatch) -> None:
    from vptoolkit.dataset.release.options import release_created

    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    assert release_created("1000-01-01T00:00:00+01:00", None) == "0999-12-31T23:00:00Z"
    assert release_created("0042-03-04T05:06:07", None) == "0042-03-04T05:06:07Z"


def test_cli_pack_refuses_a_created_beyond_9999_in_one_line(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    build = _write_build(tmp_path / "build")
    result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release"),
                                       "--created", "9999-12-31T23:59:59-01:00"])
    assert result.exit_code == 2, result.output
    assert result.output.startswith("vptool: error: created: ") and result.output.count("\n") == 1
    assert not (tmp_path / "release").exists()


# --------------------------------------------------------------------------- verify rows


def test_verify_without_manifest_and_croissant_checks_every_archive_and_fails(
        release_copy: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    (release_copy / "SHA256SUMS").unlink()
    (release_copy / "croissant.json").unlink()
    report = verify(release_copy)
    assert not report.ok and report.kind == "release"
    assert ("missing", "SHA256SUMS") in [(p.kind, p.target) for p in report.problems]
    assert report.arrays_checked == 2 * len(ARRAY_NAMES)  # the .h5 is checked too


def test_verify_names_every_unlisted_file(release_copy: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    (release_copy / "notes.txt").write_text("added")
    (release_copy / "data" / "extra.parquet").write_bytes(b"x")
    summary = verify(release_copy).summary()
    assert "OK" in summary and "2 warnings" in summary
    assert "notes.txt" in summary and "data/extra.parquet" in summary


def test_verify_blames_the_manifest_for_a_bad_digest_line(release_copy: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    manifest = release_copy / "SHA256SUMS"
    lines = manifest.read_text().splitlines()
    index = next(i for i, line in enumerate(lines) if line.endswith("  README.md"))
    lines[index] = "0" * 64 + "  README.md"
    manifest.write_text("\n".join(lines) + "\n")
    report = verify(release_copy)
    assert [(p.kind, p.target) for p in report.problems] == [("manifest", "SHA256SUMS")]
    assert "README.md" in report.problems[0].detail


def test_verify_skips_an_archive_it_cannot_open_for_lack_of_a_package(
        release_copy: Path, monkeypatch) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main
    from vptoolkit.dataset.store import reader

    def no_zarr() -> None:
        raise MissingDependencyError("zarr: not importable; install it with pip install "
                                     "'vptoolkit[dataset]'")

    monkeypatch.setattr(reader, "require_zarr", no_zarr)
    from vptoolkit.dataset.release.manifest import verify

    report = verify(release_copy)
    assert report.problems == [] and report.ok  # the files and the HDF5 arrays were verified
    assert [p.target for p in report.skipped] == ["mini.zarr.zip"]
    report.raise_if_failed()
    result = CliRunner().invoke(main, ["verify", str(release_copy)])
    assert result.exit_code == 0, result.output
    assert ": OK (" in result.stdout and "skipped mini.zarr.zip: arrays not checked" in (
        result.stdout) and "vptoolkit[dataset]" in result.stdout
    # A damaged file still fails, the skipped archive aside.
    (release_copy / "README.md").write_text("edited\n")
    assert CliRunner().invoke(main, ["verify", str(release_copy)]).exit_code == 1
    # A lone Zarr archive: nothing could be verified at all.
    report = verify(release_copy / "mini.zarr.zip")
    assert not report.ok and report.nothing_verified
    with pytest.raises(MissingDependencyError, match="vptoolkit\\[dataset\\]"):
        report.raise_if_failed()
    result = CliRunner().invoke(main, ["verify", str(release_copy / "mini.zarr.zip")])
    assert result.exit_code == 2 and "NOT VERIFIED" in result.stderr and result.stdout == ""


def test_verify_prints_its_summary_once(release_copy: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    (release_copy / "README.md").write_text("edited\n")
    result = CliRunner().invoke(main, ["verify", str(release_copy)])
    assert result.exit_code == 1
    assert result.stdout == "" and result.stderr.count("README.md") == 1
    assert len(result.stderr.splitlines()) == 1


def test_open_dataset_falls_back_to_the_container_it_can_read(release, monkeypatch) -> None:
    from vptoolkit.data import open_dataset
    from vptoolkit.dataset.store import containers

    monkeypatch.setattr(containers, "zarr_is_usable", lambda: False)
    with open_dataset(release.path) as dataset:
        assert dataset.path.name == "mini.h5" and len(dataset) == N_MODELS


def test_an_old_zarr_says_what_to_install(monkeypatch, release) -> None:
    import types

    from vptoolkit.dataset.store import containers, reader

    old = types.SimpleNamespace(__version__="2.18.3")
    monkeypatch.setattr(containers, "require", lambda module, extra=None: old)
    with pytest.raises(MissingDependencyError, match=r"zarr 2.18.3: .*pip install 'zarr>=3'"):
        reader.open_store(release.zarr_zip)


# --------------------------------------------------------------------------- Parquet only


@pytest.fixture(scope="module")
def parquet_release(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from vptoolkit.dataset.release.pack import pack_release

    base = tmp_path_factory.mktemp("parquet-only")
    build = _write_build(base / "build")
    return pack_release(build, base / "release",
                        ReleaseOptions(created=CREATED, formats=["parquet"])).path


def test_a_parquet_only_release_verifies_by_its_hashes(parquet_release: Path,
                                                       tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    result = CliRunner().invoke(main, ["verify", str(parquet_release)])
    assert result.exit_code == 0, result.output
    assert "OK" in result.output
    copy = Path(shutil.copytree(parquet_release, tmp_path / "release"))
    shard = next(iter(sorted((copy / "data").glob("*.parquet"))))
    data = bytearray(shard.read_bytes())
    data[len(data) // 2] ^= 0x5A
    shard.write_bytes(bytes(data))
    result = CliRunner().invoke(main, ["verify", str(copy)])
    assert result.exit_code == 1, result.output
    assert shard.name in result.output


@pytest.mark.parametrize("command", [
    ["info", "{release}"],
    ["evaluate", "{predictions}", "--dataset", "{release}"],
    ["predict", "--dataset", "{release}"],
    ["report", "{release}", "-o", "{out}"],
    ["train", "{release}", "-o", "{out}"],
], ids=lambda command: command[0])
def test_readers_say_in_one_line_how_to_read_a_parquet_only_release(
        parquet_release: Path, tmp_path: Path, command: list[str]) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    predictions = tmp_path / "p.npz"
    np.savez(predictions, names=np.array(["airplane_0000"]),
             directions=np.zeros((1, 4, 3)) + [0.0, 0.0, 1.0])
    fill = {"release": str(parquet_release), "predictions": str(predictions),
            "out": str(tmp_path / "out")}
    result = CliRunner().invoke(main, [part.format(**fill) for part in command])
    assert result.exit_code == 2, result.output
    assert "Parquet-only release" in result.output and "datasets" in result.output, result.output
    assert result.output.count("vptool: error:") == 1 and "Traceback" not in result.output


def test_open_dataset_says_how_to_read_a_parquet_only_release(parquet_release: Path) -> None:
    from vptoolkit.data import open_dataset

    with pytest.raises(InputError, match="Parquet-only release.*datasets"):
        open_dataset(parquet_release)


# --------------------------------------------------------------------------- card workflow


def test_update_card_rewrites_croissant_and_manifest_only(release_copy: Path) -> None:
    from vptoolkit.dataset.release.descriptions import update_card
    from vptoolkit.dataset.release.manifest import verify

    before = {p.name: p.read_bytes() for p in release_copy.iterdir() if p.is_file()}
    assert update_card(release_copy) == ["croissant.json", "SHA256SUMS"]
    assert before["croissant.json"] == (release_copy / "croissant.json").read_bytes()
    card = release_copy / "README.md"
    text = card.read_text(encoding="utf-8").replace(
        "geometric proxies", "geometric proxies (ask someone@example.org)")
    card.write_text(text, encoding="utf-8")
    assert not verify(release_copy).ok
    update_card(release_copy)
    assert verify(release_copy).ok
    document = json.loads((release_copy / "croissant.json").read_text())
    assert "someone@example.org" in document["rai:dataLimitations"]
    for name, content in before.items():
        if name not in ("README.md", "croissant.json", "SHA256SUMS"):
            assert (release_copy / name).read_bytes() == content, name


def test_update_card_refuses_when_an_archive_changed(release_copy: Path) -> None:
    from vptoolkit.dataset.release.descriptions import update_card

    archive = release_copy / "mini.h5"
    data = bytearray(archive.read_bytes())
    data[-10] ^= 0xFF
    archive.write_bytes(bytes(data))
    with pytest.raises(VerificationError, match="mini.h5: differs from SHA256SUMS"):
        update_card(release_copy)


@pytest.mark.parametrize("croissant", ["[" * 200_000, "[1, 2]"], ids=["nested", "a-list"])
def test_cli_update_card_refuses_a_croissant_it_cannot_read(release_copy: Path,
                                                            croissant: str) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    (release_copy / "croissant.json").write_text(croissant)
    result = CliRunner().invoke(main, ["pack", "--update-card", str(release_copy)])
    assert result.exit_code == 2, result.output
    assert result.output.startswith("vptool: error: croissant.json: ")
    assert result.output.count("\n") == 1 and "Traceback" not in result.output


def _update_card_cli(release_copy: Path):
    from click.testing import CliRunner

    from vptoolkit.cli import main

    return CliRunner().invoke(main, ["pack", "--update-card", str(release_copy)])


def _unchanged(release_copy: Path, before: dict[str, bytes]) -> None:
    for name in ("croissant.json", "SHA256SUMS"):
        assert (release_copy / name).read_bytes() == before[name], name


def _tamper_copied_shard(release_copy: Path) -> None:
    shard = next(iter(sorted((release_copy / "data").glob("*.parquet"))))
    shutil.copy(shard, shard.with_name("extra-00000-of-00001.parquet"))


def _tamper_croissant(release_copy: Path) -> None:
    path = release_copy / "croissant.json"
    document = json.loads(path.read_text(encoding="utf-8"))
    document["license"] = "https://example.org/mine"
    document["name"] = "someone else's"
    path.write_text(json.dumps(document), encoding="utf-8")


def _tamper_card_link(release_copy: Path) -> None:
    card = release_copy / "README.md"
    elsewhere = release_copy.parent / "card-elsewhere.md"
    elsewhere.write_bytes(card.read_bytes() + b"\nedited\n")
    card.unlink()
    card.symlink_to(elsewhere)


@pytest.mark.parametrize(("tamper", "message"), [
    (_tamper_copied_shard, r"data/extra-00000-of-00001.parquet: not listed in SHA256SUMS"),
    (_tamper_croissant, r"croissant.json: differs from SHA256SUMS"),
    (_tamper_card_link, r"README.md: a symbolic link"),
], ids=["unlisted-shard", "edited-croissant", "card-symlink"])
def test_update_card_blesses_only_the_card(release_copy: Path, tamper, message: str) -> None:
    from vptoolkit.dataset.release.manifest import verify

    tamper(release_copy)
    before = {name: (release_copy / name).read_bytes()
              for name in ("croissant.json", "SHA256SUMS")}
    result = _update_card_cli(release_copy)
    assert result.exit_code == 1, result.output
    assert re.search(message, result.output), result.output
    assert result.output.count("\n") == 1 and "Traceback" not in result.output
    _unchanged(release_copy, before)
    report = verify(release_copy)
    assert not report.ok or report.warnings


def test_update_card_puts_croissant_back_when_the_manifest_cannot_be_written(
        release_copy: Path, monkeypatch) -> None:
    from vptoolkit.dataset.release import descriptions

    card = release_copy / "README.md"
    card.write_text(card.read_text(encoding="utf-8") + "\nA correction.\n", encoding="utf-8")
    before = {name: (release_copy / name).read_bytes()
              for name in ("croissant.json", "SHA256SUMS")}
    real = descriptions.write_bytes_atomic

    def failing(path, payload):
        if Path(path).name == "SHA256SUMS":
            raise OSError(28, "No space left on device", str(path))
        return real(path, payload)

    monkeypatch.setattr(descriptions, "write_bytes_atomic", failing)
    with pytest.raises(OSError, match="No space left"):
        descriptions.update_card(release_copy)
    _unchanged(release_copy, before)
    assert [p.name for p in release_copy.iterdir() if p.name.startswith(".")] == []


@pytest.mark.parametrize("name", ["README.md", "SHA256SUMS"])
def test_cli_update_card_on_a_file_that_is_not_utf8_is_one_line(release_copy: Path,
                                                                 name: str) -> None:
    path = release_copy / name
    path.write_bytes(path.read_bytes() + b"\xff\xfe latin-1 \xe9\n")
    before = {n: (release_copy / n).read_bytes() for n in ("croissant.json", "SHA256SUMS")}
    result = _update_card_cli(release_copy)
    assert result.exit_code in (1, 2), result.output
    assert f"{name}: not UTF-8 text" in result.output
    assert result.output.count("\n") == 1 and "Traceback" not in result.output
    _unchanged(release_copy, before)


def test_cli_update_card(release_copy: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    result = CliRunner().invoke(main, ["pack", "--update-card", str(release_copy)])
    assert result.exit_code == 0, result.output
    assert "croissant.json, SHA256SUMS" in result.stdout


# --------------------------------------------------------------------------- light install


def test_a_command_needing_an_extra_says_which_in_one_line(monkeypatch, tmp_path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    def missing(*args: object, **kwargs: object) -> None:
        raise ModuleNotFoundError("No module named 'trimesh'", name="trimesh")

    import vptoolkit.io

    monkeypatch.setattr(vptoolkit.io, "load_mesh", missing)
    mesh = tmp_path / "a.off"
    mesh.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    result = CliRunner().invoke(main, ["measures", str(mesh)])
    assert result.exit_code == 2
    assert result.stderr == ("vptool: error: trimesh: not installed; this command needs it: "
                             "pip install 'vptoolkit[measures]'\n")


def test_plain_install_needs_no_heavy_package() -> None:
    import tomllib

    project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())
    core = [re.split(r"[<>=;\[ ]", dep)[0] for dep in project["project"]["dependencies"]]
    assert sorted(core) == ["click", "h5py", "numpy", "packaging", "tqdm"]
    extras = project["project"]["optional-dependencies"]
    assert "vptoolkit[measures,clean,dataset,cluster,learn,pictures,remote]" in extras["all"]
    for package in ("numba", "trimesh"):
        assert any(dep.startswith(package) for dep in extras["measures"])
    assert {"datasets", "mlcroissant"} <= {re.split(r"[<>=]", d)[0] for d in extras["dev"]}


def test_the_sample_licence_table_covers_every_sample_mesh() -> None:
    from vptoolkit.dataset.release.licenses import read_licenses
    from vptoolkit.samples import sample_names, sample_path

    table = read_licenses(sample_path("bunny.ply").parent / "LICENSES.csv")
    assert sorted(table) == sorted(Path(name).stem for name in sample_names())
    assert {row["license"] for row in table.values()} == {"mit", "zlib"}


LIGHT_SCRIPT = """
import sys
from vptoolkit.data import open_dataset

with open_dataset(sys.argv[1]) as dataset:
    names = [item["name"] for item in dataset]
    shapes = {item["quality"].shape for item in dataset.split("validation")}
heavy = [m for m in ("torch", "open3d", "pymeshlab", "numba", "trimesh") if m in sys.modules]
print(len(names), sorted(shapes), heavy)
"""


@pytest.mark.slow
def test_a_plain_pip_install_reads_a_release(release, tmp_path: Path) -> None:
    """The README's light install: `pip install vptoolkit`, no extras, then load a release."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, capture_output=True)
    python = venv / "bin" / "python"
    repo = Path(__file__).resolve().parents[1]
    install = subprocess.run([str(python), "-m", "pip", "install", "--quiet",
                              "--disable-pip-version-check", str(repo)],
                             capture_output=True, text=True)
    if install.returncode != 0:
        message = f"pip install failed: {install.stderr.strip()[-500:]}"
        if os.environ.get("VPTOOLKIT_REQUIRE_ALL") == "1":
            pytest.fail(message)
        pytest.skip(message)
    size = sum(p.stat().st_size for p in venv.rglob("*") if p.is_file() and not p.is_symlink())
    assert size < 250 * 2**20, f"{size / 2**20:.0f} MiB"
    listed = subprocess.run([str(python), "-m", "pip", "list", "--format=freeze"],
                            capture_output=True, text=True, check=True).stdout.lower()
    for heavy in ("open3d", "torch", "numba", "pymeshlab", "trimesh"):
        assert f"\n{heavy}" not in f"\n{listed}", heavy
    environment = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    result = subprocess.run([str(python), "-W", "error", "-c", LIGHT_SCRIPT, str(release.path)],
                            capture_output=True, text=True, env=environment, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == f"{N_MODELS} [({N_VIEWS}, 4)] []"
    info = subprocess.run([str(venv / "bin" / "vptool"), "info", str(release.path)],
                          capture_output=True, text=True, env=environment)
    assert info.returncode == 0 and f"models {N_MODELS}" in info.stdout


def test_cli_pack_options_reach_the_release(tmp_path: Path, licenses_csv: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    build = _write_build(tmp_path / "build")
    release = tmp_path / "release"
    result = CliRunner().invoke(main, [
        "pack", str(build), str(release), "--formats", "parquet,hdf5", "--version", "0.2.0",
        "--created", "2026-03-04T06:06:07+01:00", "--licenses", str(licenses_csv),
        "--pretty-name", "CLI viewpoints", "--source-url", "https://example.org/src",
        "--license-name", "mixed", "--license-link", "https://example.org/terms"])
    assert result.exit_code == 0, result.output
    assert f"version 0.2.0, created {CREATED}" in result.stdout
    assert (release / "vptoolkit-viewpoints.h5").is_file()
    assert not list(release.glob("*.zarr.zip"))
    card = (release / "README.md").read_text(encoding="utf-8")
    assert 'license_name: "mixed"' in card and 'license_link: "https://example.org/terms"' in card
    assert card.startswith('---\npretty_name: "CLI viewpoints"\n')
    bad = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "r2"), "--version", "v1"])
    assert bad.exit_code == 2
    assert bad.stderr == "vptool: error: version: 'v1' is not MAJOR.MINOR.PATCH (e.g. 1.0.0)\n"


def test_a_zarr_directory_store_gets_the_umask_mode_not_0700(tmp_path: Path) -> None:
    build = _write_build(tmp_path / "build")
    mask = os.umask(0)
    os.umask(mask)
    assert (build / "dataset.zarr").stat().st_mode & 0o777 == 0o777 & ~mask


# --------------------------------------------------------------------------- licences and card


def test_update_card_refuses_a_card_that_lost_the_heading_of_an_rai_field(
        release_copy: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    card = release_copy / "README.md"
    before = (release_copy / "croissant.json").read_bytes()
    card.write_text(card.read_text(encoding="utf-8").replace("## Uses\n", "## Intended uses\n"),
                    encoding="utf-8")
    result = CliRunner().invoke(main, ["pack", "--update-card", str(release_copy)])
    assert result.exit_code == 2
    assert len(result.output.strip().splitlines()) == 1
    assert "rai:dataUseCases is read from the card's section '## Uses'" in result.output
    assert (release_copy / "croissant.json").read_bytes() == before


@pytest.mark.parametrize(("options", "message"), [
    (["--license", "CC BY"], "--license: 'CC BY' is not an SPDX licence identifier"),
    (["--licenses", "TABLE"], "licenses.csv: line 3: 'free for all' is not an SPDX licence"),
])
def test_licences_must_be_spdx_identifiers_or_urls(tmp_path: Path, options: list[str],
                                                    message: str) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    build = _write_build(tmp_path / "build")
    table = tmp_path / "licenses.csv"
    table.write_text("name,license,author,url\nairplane_0000,CC-BY-4.0,,\n"
                     "chair_0001,free for all,,\nchair_0002,https://example.org/terms,,\n",
                     encoding="utf-8")
    options = [str(table) if part == "TABLE" else part for part in options]
    result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release"), *options])
    assert result.exit_code == 2
    assert result.output.startswith(f"vptool: error: {message}")
    assert len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "release").exists()


def test_one_licence_for_every_model_fills_records_shards_and_card(tmp_path: Path) -> None:
    import pyarrow.parquet as pq
    from click.testing import CliRunner

    from vptoolkit.cli import main
    from vptoolkit.data import open_dataset

    build = _write_build(tmp_path / "build")
    release = tmp_path / "release"
    result = CliRunner().invoke(main, ["pack", str(build), str(release), "--license",
                                       "CC-BY-4.0", "--force-license", "--creator", "Jane Doe",
                                       "--created", CREATED])
    assert result.exit_code == 0, result.output
    assert "warning" not in result.stderr
    with open_dataset(release) as dataset:
        assert {r["provenance"]["license"] for r in dataset.records} == {"CC-BY-4.0"}
    licences = pq.read_table(release / "data/train-00000-of-00001.parquet").column("license")
    assert set(licences.to_pylist()) == {"CC-BY-4.0"}
    card = (release / "README.md").read_text(encoding="utf-8")
    assert re.search(r'^license: "CC-BY-4.0"$', card, re.MULTILINE)
    assert "Every source mesh is under `CC-BY-4.0`" in card
    assert "*Who created it?* Jane Doe, with vptoolkit" in card
    assert "@misc{viewpoint_quality_of_modelnet40_mini_models_2026," in card
    assert "  author  = {Jane Doe}," in card and "  version = {1.0.0}," in card
    document = json.loads((release / "croissant.json").read_text(encoding="utf-8"))
    assert document["creator"]["name"] == "Jane Doe"
    assert document["license"] == "CC-BY-4.0"


def test_pack_without_a_licence_warns_on_stderr(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    build = _write_build(tmp_path / "build")
    result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release")])
    assert result.exit_code == 0, result.output
    assert "vptool: warning: no licence given for the source meshes" in result.stderr
    card = (tmp_path / "release/README.md").read_text(encoding="utf-8")
    assert "no licence given" not in card  # the card's licence note says it in its words
    assert "vptoolkit was given no licence for them" in card


def test_card_states_modelnet_terms_lists_the_loaded_columns_and_names_mlcroissant(
        release) -> None:
    from vptoolkit.dataset.release.card import MODELNET_TERMS, _terms_block

    card = release.card.read_text(encoding="utf-8")
    assert MODELNET_TERMS in card  # the source, ModelNet40-mini, is recognised
    assert _terms_block("my-scans") == ""
    assert "| `points` | float32 | (200, 3) | points sampled by area on the cleaned mesh |" in card
    assert "| `mesh_faces` | int32 | (n, 3) |" in card
    assert ("| `label` | int64 | scalar | class label: the category's index in the sorted "
            "category names |") in card
    assert "pip install 'mlcroissant[parquet]'" in card
    assert 'records(record_set="models")' in card


def test_a_licence_given_by_url_is_other_on_the_hub_with_its_link(tmp_path: Path) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    url = "https://example.org/terms"
    result = pack_release(_write_build(tmp_path / "build"), tmp_path / "release",
                          ReleaseOptions(license=url, formats=["hdf5"], force_license=True))
    header = result.card.read_text(encoding="utf-8").split("\n---\n")[0]
    assert 'license: "other"\nlicense_name: "custom"\nlicense_link: "https://example.org/terms"' \
        in header
    assert json.loads(result.croissant.read_text(encoding="utf-8"))["license"] == url


def test_the_same_build_and_shard_size_pack_to_the_same_bytes(sharded, tmp_path: Path) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    again = pack_release(_write_build(tmp_path / "build"), tmp_path / "release",
                         ReleaseOptions(created=CREATED, shard_size="30KB"))
    assert again.files == sharded.files
