"""A release of a build with ``--measures VE,NVT,SL``: the card, Croissant, the Parquet shards
and their Hugging Face features follow the store's three measures, and ``verify`` passes."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fixtures.environment import require_package
from vptoolkit.cli import main
from vptoolkit.samples import sample_path

THREE = ("VE", "NVT", "SL")
N_VIEWS = 60
CREATED = "2026-02-03T04:05:06Z"


@pytest.fixture(scope="module")
def release(tmp_path_factory: pytest.TempPathFactory):
    """Four bundled samples built with three measures, packed in every format."""
    from vptoolkit.dataset.release.options import FORMATS, ReleaseOptions
    from vptoolkit.dataset.release.pack import pack_release

    root = tmp_path_factory.mktemp("measures-release")
    for category, sample in (("bottle", "bottle.obj"), ("mug", "mug.obj"),
                             ("table", "table.obj"), ("toy", "lego.obj")):
        (root / "src" / category).mkdir(parents=True)
        shutil.copy(sample_path(sample), root / "src" / category / sample)
    built = CliRunner().invoke(main, [
        "build-dataset", str(root / "src"), str(root / "build"), "--views", str(N_VIEWS),
        "--resolution", "48", "--points", "150", "--no-clean", "--measures", ",".join(THREE)])
    assert built.exit_code == 0, built.output
    return pack_release(root / "build", root / "release",
                        ReleaseOptions(formats=FORMATS, created=CREATED))


def test_the_card_describes_the_three_measures(release) -> None:
    import yaml

    card = release.card.read_text(encoding="utf-8")
    assert "the three\nviewpoint quality measures VE, NVT, SL evaluated for" in card
    assert "Columns of every last axis of size 3, in this order: VE, NVT, SL." in card
    assert "Raw values are in each measure's own unit" in card
    assert "VR is a fraction" not in card
    assert "# (views, 3) of model 0, columns VE, NVT, SL" in card
    assert "| VE | viewpoint entropy | higher | bits |" in card
    assert "| NVT | number of visible triangles | higher | - |" in card
    assert "| SL | silhouette length | higher | - |" in card
    assert "VKL" not in card and "VMI" not in card
    header = yaml.safe_load(card.split("---\n")[1])
    default = next(c for c in header["dataset_info"] if c["config_name"] == "default")
    features = {f["name"]: f for f in default["features"]}
    assert features["quality"]["dtype"]["array2_d"]["shape"] == [N_VIEWS, 3]
    assert features["best_index"] == {"name": "best_index", "list": "int64", "length": 3}
    assert ("| `quality` | float32 | (60, 3) | normalised quality per view, columns VE, NVT, "
            "SL, 1 = best |") in card


def test_croissant_fields_name_the_columns_and_have_their_shapes(release) -> None:
    document = json.loads(release.croissant.read_text(encoding="utf-8"))
    assert "quality measures VE, NVT, SL for 60 views" in document["description"]
    models = next(r for r in document["recordSet"] if r["@id"] == "models")
    fields = {f["name"]: f for f in models["field"]}
    assert fields["quality"]["arrayShape"] == f"{N_VIEWS},3"
    assert fields["quality_raw"]["description"] == (
        "raw measures per view, columns VE, NVT, SL, NaN where nothing is seen")
    assert fields["worst_value"]["arrayShape"] == "3"


def test_parquet_shards_hold_the_store_columns_with_their_features(release) -> None:
    import pyarrow.parquet as pq

    from vptoolkit.data import open_dataset

    rows = {}
    for shard in release.parquet:
        if shard.parent.name != "data":
            continue
        features = json.loads(pq.read_schema(shard).metadata[b"huggingface"])["info"]["features"]
        assert features["quality"] == {"_type": "Array2D", "dtype": "float32",
                                       "shape": [N_VIEWS, 3]}
        assert features["best_value"] == {"_type": "List", "length": 3,
                                          "feature": {"_type": "Value", "dtype": "float32"}}
        table = pq.read_table(shard).to_pylist()
        rows.update({row["name"]: row for row in table})
    with open_dataset(release.path) as dataset:
        assert sorted(rows) == sorted(dataset.names)
        for name, row in rows.items():
            item = dataset[name]
            np.testing.assert_array_equal(np.array(row["quality_raw"], np.float32),
                                          item["quality_raw"])
            assert row["best_index"] == item["best_index"].tolist()


def test_datasets_loads_the_three_columns_offline(release, tmp_path: Path, monkeypatch) -> None:
    require_package("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    import datasets

    from vptoolkit.data import open_dataset

    loaded = datasets.load_dataset(str(release.path), cache_dir=str(tmp_path / "cache"))
    with open_dataset(release.path) as reference:
        for split, rows in loaded.items():
            first = rows.with_format("numpy")[0]
            expected = reference.split(split)[0]
            assert first["quality"].shape == (N_VIEWS, 3)
            np.testing.assert_array_equal(first["quality"], expected["quality"])
            np.testing.assert_array_equal(first["worst_index"],
                                          reference.array("worst_index")[
                                              reference.names.index(first["name"])])


def test_verify_passes_and_every_archive_holds_the_measures(release) -> None:
    from vptoolkit.dataset.store.reader import open_store

    result = CliRunner().invoke(main, ["verify", str(release.path)])
    assert result.exit_code == 0, result.output
    for archive in (release.path / f"{release.name}.h5", release.zarr_zip):
        with open_store(archive) as store:
            assert store.measures == THREE and store.attrs["higher_is_better"] == [True] * 3


# rdflib and pandas, under mlcroissant, warn about their own APIs; not ours.
@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:ConjunctiveGraph is deprecated:DeprecationWarning")
@pytest.mark.filterwarnings("ignore:The inplace keyword in DataFrame.reset_index")
def test_mlcroissant_reads_a_record_of_three_columns(release) -> None:
    require_package("mlcroissant")
    import mlcroissant

    dataset = mlcroissant.Dataset(jsonld=str(release.croissant))
    model = next(iter(dataset.records(record_set="models")))
    assert np.asarray(model["models/quality"]).shape == (N_VIEWS, 3)
    assert np.asarray(model["models/best_index"]).shape == (3,)


def test_a_store_with_a_measure_the_registry_does_not_know_is_not_packed(release,
                                                                         tmp_path: Path) -> None:
    import h5py

    store = Path(shutil.copy(release.path / f"{release.name}.h5", tmp_path / "dataset.h5"))
    with h5py.File(store, "a") as handle:
        handle.attrs["measures"] = np.array(["VE", "NVT", "FUTURE"], dtype=h5py.string_dtype())
    info = CliRunner().invoke(main, ["info", str(store)])
    assert info.exit_code == 0 and "FUTURE (higher is better)" in info.output
    packed = CliRunner().invoke(main, ["pack", str(store), str(tmp_path / "release")])
    assert packed.exit_code == 2
    assert "measure 'FUTURE'" in packed.stderr and packed.stderr.count("\n") == 1
