"""The numpy-only loader vptoolkit.data over every store format, and over a store of other
measures than the paper's four."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.paths import REPO
from fixtures.releases import N_MODELS
from fixtures.stores import (
    BUILD,
    FAILURES,
    MODELS,
    N_POINTS,
    N_VIEWS,
    STORE_NAMES,
    synthetic_entries,
    write_synthetic,
)
from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.dataset.store.schema import published_split
from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.sphere import fibonacci_sphere

LOADER_MUST_NOT_IMPORT = ("torch", "open3d", "pymeshlab", "numba", "trimesh")


@pytest.fixture(params=list(STORE_NAMES))
def dataset(request: pytest.FixtureRequest,
            stores: dict[str, Path]) -> Iterator[ViewpointDataset]:
    with open_dataset(stores[request.param]) as opened:
        yield opened


def test_metadata(dataset: ViewpointDataset) -> None:
    assert len(dataset) == len(MODELS)
    assert dataset.names == [name for _, name, _ in MODELS]
    assert dataset.categories == [category for category, _, _ in MODELS]
    assert dataset.splits == [published_split(split) for _, _, split in MODELS]
    assert set(dataset.splits) <= {"train", "validation", "test"}
    assert dataset.measures == PAPER_MEASURES
    assert dataset.views.dtype == np.float64 and dataset.views.shape == (N_VIEWS, 3)
    np.testing.assert_array_equal(dataset.views, fibonacci_sphere(N_VIEWS))
    assert not dataset.views.flags.writeable
    assert dataset.attrs["n_models"] == len(MODELS) and dataset.attrs["backend"] == "raster"
    assert dataset.failures == FAILURES
    assert [record["name"] for record in dataset.records] == dataset.names
    assert dataset.record("chair_0001")["n_faces"] == len(synthetic_entries()[3].faces)


def test_items_hold_the_stored_arrays(dataset: ViewpointDataset) -> None:
    for entry, item in zip(synthetic_entries(), dataset):
        assert (item["name"], item["category"], item["split"]) == (
            entry.name, entry.category, published_split(entry.split))
        for key, dtype, shape in [("points", np.float32, (N_POINTS, 3)),
                                  ("normals", np.float32, (N_POINTS, 3)),
                                  ("quality", np.float32, (N_VIEWS, 4)),
                                  ("quality_raw", np.float32, (N_VIEWS, 4)),
                                  ("best_index", np.int64, (4,))]:
            assert item[key].dtype == dtype and item[key].shape == shape, key
            np.testing.assert_array_equal(item[key], getattr(entry, key).astype(dtype))
        assert item["views"] is dataset.views
        np.testing.assert_array_equal(item["quality"][item["best_index"], np.arange(4)], 1.0)


def test_formats_load_identically(stores: dict[str, Path]) -> None:
    with open_dataset(stores["zarr"]) as reference:
        for kind in ("zarr-zip", "hdf5"):
            with open_dataset(stores[kind]) as other:
                assert other.names == reference.names and other.attrs == reference.attrs
                for a, b in zip(reference, other):
                    assert a.keys() == b.keys()
                    for key in a:
                        np.testing.assert_array_equal(a[key], b[key], err_msg=f"{kind} {key}")
                for name in reference.names:
                    for x, y in zip(reference.mesh(name), other.mesh(name)):
                        np.testing.assert_array_equal(x, y)


def test_keys(dataset: ViewpointDataset) -> None:
    assert dataset[-1]["name"] == "chair_0002"
    assert dataset[np.int64(1)]["name"] == "airplane_0002"
    np.testing.assert_array_equal(dataset["chair_0001"]["points"], dataset[3]["points"])
    with pytest.raises(IndexError):
        dataset[len(MODELS)]
    with pytest.raises(IndexError):
        dataset[-len(MODELS) - 1]
    with pytest.raises(KeyError, match="sofa_0001"):
        dataset["sofa_0001"]
    with pytest.raises(InputError, match="key: expected an integer index or a model name"):
        dataset[1.0]  # type: ignore[index]


def test_split(dataset: ViewpointDataset) -> None:
    train = dataset.split("train")
    assert train.names == ["airplane_0001", "chair_0001", "chair_0002"]
    assert set(train.splits) == {"train"} and train.categories == ["airplane", "chair", "chair"]
    assert dataset.split("validation").names == ["airplane_0003"]
    assert dataset.split("val").names == ["airplane_0003"]  # the stored name is an alias
    assert dataset.split("test").names == ["airplane_0002"]
    assert len(train.split("test")) == 0
    np.testing.assert_array_equal(train[1]["points"], dataset["chair_0001"]["points"])
    assert train[-1]["name"] == "chair_0002"
    with pytest.raises(KeyError, match="airplane_0002: no such model in split 'train'"):
        train["airplane_0002"]
    with pytest.raises(InputError, match="split: unknown split 'training'"):
        dataset.split("training")
    train.close()  # a split does not own the store
    assert dataset[0]["name"] == "airplane_0001"


def test_items_carry_category_and_the_label_of_the_sorted_class_map(
        dataset: ViewpointDataset) -> None:
    assert dataset.class_names == ["airplane", "chair"] == dataset.attrs["class_names"]
    assert [(item["category"], item["label"]) for item in dataset] == [
        (category, ["airplane", "chair"].index(category)) for category, _, _ in MODELS]
    assert dataset.labels.tolist() == [0, 0, 0, 1, 1] and dataset.labels.dtype == np.int64
    train = dataset.split("train")
    assert train.class_names == dataset.class_names and train.labels.tolist() == [0, 1, 1]


def test_a_store_without_class_names_and_string_arrays_still_loads(tmp_path: Path) -> None:
    import h5py

    store = write_synthetic(tmp_path / "older.h5")
    with h5py.File(store, "r+") as handle:
        for name in ("names", "categories", "splits", "labels"):
            del handle[name]
        del handle.attrs["class_names"]
    with open_dataset(store) as older:
        assert "class_names" not in older.attrs
        assert older.class_names == ["airplane", "chair"]
        assert older.labels.tolist() == [0, 0, 0, 1, 1] and older[3]["label"] == 1


@pytest.mark.parametrize(("stored", "message"), [([0, 0, 0, 0, 1], None),
                                                  ([0, 0, 0, 1, 2], "labels does not hold"),
                                                  ([0, 1], "labels does not hold")])
def test_labels_are_the_stored_array(tmp_path: Path, stored: list[int],
                                     message: str | None) -> None:
    import h5py

    store = write_synthetic(tmp_path / "dataset.h5")
    with h5py.File(store, "r+") as handle:
        del handle["labels"]
        handle["labels"] = np.array(stored, np.int64)
    if message is not None:
        with pytest.raises(InputError, match=f"dataset.h5: {message} a class label"):
            open_dataset(store)
        return
    with open_dataset(store) as dataset:
        assert dataset.labels.tolist() == stored and dataset[3]["label"] == 0
        assert dataset.class_names == ["airplane", "chair"]


def test_slices_and_index_lists_give_datasets(dataset: ViewpointDataset) -> None:
    head = dataset[0:3]
    assert isinstance(head, ViewpointDataset)
    assert head.names == dataset.names[0:3]
    assert dataset[::-2].names == dataset.names[::-2]
    assert dataset[[0, 2]].names == ["airplane_0001", "airplane_0003"]
    assert dataset[np.array([4, -5])].names == ["chair_0002", "airplane_0001"]
    assert dataset[np.array([True, False, False, False, True])].names == [
        "airplane_0001", "chair_0002"]
    assert len(dataset[[]]) == 0
    np.testing.assert_array_equal(dataset[[3]][0]["points"], dataset[3]["points"])
    assert dataset.split("train")[1:].names == ["chair_0001", "chair_0002"]
    with pytest.raises(IndexError, match="index 5 out of range"):
        dataset[[0, 5]]
    with pytest.raises(IndexError, match="boolean index"):
        dataset[np.array([True, False])]


def test_array_stacks_one_key_of_every_item(dataset: ViewpointDataset) -> None:
    entries = synthetic_entries()
    quality = dataset.array("quality")
    assert quality.shape == (len(MODELS), N_VIEWS, 4) and quality.dtype == np.float32
    expected = np.stack([entry.quality for entry in entries]).astype(np.float32)
    np.testing.assert_array_equal(quality, expected)
    picked = dataset[[4, 0, 3]]
    points = np.stack([entries[i].points for i in (4, 0, 3)]).astype(np.float32)
    np.testing.assert_array_equal(picked.array("points"), points)
    assert picked.array("best_index").dtype == np.int64
    assert picked.array("name").tolist() == ["chair_0002", "airplane_0001", "chair_0001"]
    assert picked.array("category").tolist() == ["chair", "airplane", "chair"]
    assert picked.array("split").tolist() == ["train", "train", "train"]
    assert picked.array("label").tolist() == [1, 0, 1]
    assert dataset[[]].array("quality").shape == (0, N_VIEWS, 4)
    with pytest.raises(InputError, match="key: expected one of"):
        dataset.array("mesh_faces")


def test_quality_of_uses_the_nearest_sampled_view(dataset: ViewpointDataset) -> None:
    rng = np.random.default_rng(7)
    directions = rng.normal(size=(300, 3)) * rng.uniform(0.1, 10.0, size=(300, 1))
    unit = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    nearest = np.argmax(unit @ fibonacci_sphere(N_VIEWS).T, axis=1)
    for key in ("airplane_0003", 4):
        quality = dataset.quality_of(key, directions)
        assert quality.dtype == np.float32 and quality.shape == (300, 4)
        np.testing.assert_array_equal(quality, dataset[key]["quality"][nearest])
    best = dataset[0]["best_index"]
    single = dataset.quality_of(0, dataset.views[best[2]] * 3.0)
    assert single.shape == (1, 4) and single[0, 2] == 1.0
    with pytest.raises(InputError, match="zero-length"):
        dataset.quality_of(0, [[0.0, 0.0, 0.0]])
    with pytest.raises(InputError, match="expected shape"):
        dataset.quality_of(0, np.ones((2, 2)))


def test_mesh(dataset: ViewpointDataset) -> None:
    for index, entry in enumerate(synthetic_entries()):
        vertices, faces = dataset.mesh(index)
        assert vertices.dtype == np.float32 and faces.dtype == np.int32
        np.testing.assert_array_equal(vertices, entry.vertices.astype(np.float32))
        np.testing.assert_array_equal(faces, entry.faces)
        assert faces.max() < len(vertices)
    vertices, faces = dataset.mesh("chair_0002")
    np.testing.assert_array_equal(faces, synthetic_entries()[4].faces)


def test_close(stores: dict[str, Path]) -> None:
    with open_dataset(stores["zarr-zip"]) as opened:
        train = opened.split("train")
    with pytest.raises(InputError, match="dataset is closed"):
        opened[0]
    with pytest.raises(InputError, match="dataset is closed"):
        train.mesh(0)
    assert opened.names[0] == "airplane_0001"  # metadata stays available


def test_open_dataset_finds_the_store_in_a_folder(tmp_path: Path) -> None:
    build = tmp_path / "build"
    build.mkdir()
    write_synthetic(build / "dataset.h5")
    with open_dataset(build) as opened:
        assert opened.path == build / "dataset.h5" and len(opened) == len(MODELS)
    release = tmp_path / "release"
    release.mkdir()
    write_synthetic(release / "viewpoints-v1.zarr.zip", synthetic_entries(MODELS[:2]))
    with open_dataset(release) as opened:
        assert opened.names == ["airplane_0001", "airplane_0002"]
    with pytest.raises(InputError, match="no dataset.zarr"):
        open_dataset(tmp_path / "build" / "..")


def test_empty_dataset(tmp_path: Path) -> None:
    with open_dataset(write_synthetic(tmp_path / "d.zarr.zip", [])) as opened:
        assert len(opened) == 0 and list(opened) == [] and opened.names == []
        assert len(opened.split("train")) == 0 and opened.failures == FAILURES
        with pytest.raises(IndexError):
            opened[0]


def _loaded_modules(code: str) -> list[str]:
    probe = f"{code}; import sys; print(','.join(sorted(sys.modules)))"
    output = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                            check=True, cwd=REPO).stdout.strip()
    return output.split(",")


def test_import_is_light() -> None:
    loaded = {name.split(".")[0] for name in _loaded_modules("import vptoolkit.data")}
    assert not loaded & {*LOADER_MUST_NOT_IMPORT, "zarr", "h5py"}, loaded
    assert "vptoolkit.data.torch" not in _loaded_modules("import vptoolkit.data")


def test_opening_loads_only_the_format_in_use(stores: dict[str, Path]) -> None:
    for kind, unwanted in (("hdf5", "zarr"), ("zarr-zip", "h5py")):
        loaded = _loaded_modules(
            f"from vptoolkit.data import open_dataset; open_dataset({str(stores[kind])!r})[0]"
        )
        top = {name.split(".")[0] for name in loaded}
        assert unwanted not in top and not top & set(LOADER_MUST_NOT_IMPORT), (kind, top)


FRESH_VENV_SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    from vptoolkit.data import open_dataset

    expected = np.load(sys.argv[1], allow_pickle=False)
    for path in sys.argv[2:]:
        with open_dataset(path) as dataset:
            assert dataset.names == ["airplane_0001", "airplane_0002", "airplane_0003",
                                     "chair_0001", "chair_0002"], dataset.names
            assert dataset.split("train").names == ["airplane_0001", "chair_0001", "chair_0002"]
            item = dataset["chair_0001"]
            np.testing.assert_array_equal(item["points"], expected["points"])
            np.testing.assert_array_equal(item["quality"], expected["quality"])
            np.testing.assert_array_equal(dataset.mesh("chair_0001")[1], expected["faces"])
            np.testing.assert_array_equal(dataset.quality_of(3, expected["directions"]),
                                          expected["quality_of"])
    heavy = [m for m in ("torch", "open3d", "pymeshlab", "numba", "trimesh") if m in sys.modules]
    assert not heavy, heavy
    print("ok")
    """
)


@pytest.mark.slow
def test_loader_works_in_a_fresh_venv_with_numpy_zarr_h5py(
    tmp_path: Path, stores: dict[str, Path]
) -> None:
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, capture_output=True)
    python = venv / "bin" / "python"
    install = subprocess.run(
        [str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
         "numpy", "zarr>=3", "h5py"],
        capture_output=True, text=True,
    )
    if install.returncode != 0:
        message = f"pip install numpy zarr h5py failed: {install.stderr.strip()[-500:]}"
        if os.environ.get("VPTOOLKIT_REQUIRE_ALL") == "1":
            pytest.fail(message)
        pytest.skip(message)

    with open_dataset(stores["zarr"]) as reference:
        directions = np.random.default_rng(3).normal(size=(20, 3))
        np.savez(tmp_path / "expected.npz", points=reference[3]["points"],
                 quality=reference[3]["quality"], faces=reference.mesh(3)[1],
                 directions=directions, quality_of=reference.quality_of(3, directions))
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONPATH"}
    environment["PYTHONPATH"] = str(REPO)
    result = subprocess.run(
        [str(python), "-W", "error", "-c", FRESH_VENV_SCRIPT, str(tmp_path / "expected.npz"),
         str(stores["zarr-zip"]), str(stores["hdf5"])],
        capture_output=True, text=True, env=environment, cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "ok"


# --------------------------------------------------------------------------- releases


def test_open_dataset_falls_back_to_the_container_it_can_read(mini_release, monkeypatch) -> None:
    from vptoolkit.data import open_dataset
    from vptoolkit.dataset.store import containers

    monkeypatch.setattr(containers, "zarr_is_usable", lambda: False)
    with open_dataset(mini_release.path) as dataset:
        assert dataset.path.name == "mini.h5" and len(dataset) == N_MODELS


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


# --- a store of three measures ------------------------------------------------------------


MEASURES = ("SL", "VKL", "NVT")
"""Three measures in a store's own order; VKL is the one where lower is better."""


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The synthetic models with three measure columns (the first three of four), HDF5."""
    entries = [dataclasses.replace(
        entry, quality=entry.quality[:, :3], quality_raw=entry.quality_raw[:, :3],
        best_index=entry.best_index[:3], best_value=entry.best_value[:3],
        worst_index=entry.worst_index[:3], worst_value=entry.worst_value[:3],
    ) for entry in synthetic_entries()]
    return write_synthetic(tmp_path_factory.mktemp("three") / "dataset.h5", entries,
                           attrs={**BUILD, "measures": list(MEASURES)})


def test_the_loader_follows_the_recorded_names(store: Path) -> None:
    from vptoolkit.data import open_dataset

    with open_dataset(store) as dataset:
        assert dataset.measures == MEASURES
        assert dataset.higher_is_better == (True, False, True)
        item = dataset["chair_0001"]
        assert item["quality"].shape == (N_VIEWS, 3) and item["quality_raw"].shape == (N_VIEWS, 3)
        assert item["best_index"].shape == (3,)
        assert dataset.array("quality").shape == (len(dataset), N_VIEWS, 3)
        # a direction scores the quality of the nearest view, one column per measure
        best = dataset.views[item["best_index"]]
        scored = dataset.quality_of("chair_0001", best)
        assert scored.shape == (3, 3)
        np.testing.assert_array_equal(np.diag(scored), [1.0, 1.0, 1.0])
        train = dataset.split("train")
        assert train.measures == MEASURES and train[0]["quality"].shape == (N_VIEWS, 3)


def test_the_torch_adapter_gives_one_best_view_per_measure(store: Path) -> None:
    require_package("torch")
    from vptoolkit.data.torch import ViewpointTorchDataset

    inputs = ViewpointTorchDataset(store, n_points=64, n_fps=16, seed=3)
    assert inputs.measures == MEASURES
    item = inputs[0]
    assert tuple(item["quality"].shape) == (N_VIEWS, 3)
    assert tuple(item["best_views"].shape) == (3, 3) and tuple(item["best_index"].shape) == (3,)
    np.testing.assert_allclose(item["best_views"].numpy(),
                               item["views"].numpy()[item["best_index"].numpy()])


def test_a_measure_the_registry_does_not_know_loads_but_has_no_direction(
        store: Path, tmp_path: Path) -> None:
    import shutil

    import h5py

    from vptoolkit.data import open_dataset

    copy = Path(shutil.copy(store, tmp_path / "dataset.h5"))
    with h5py.File(copy, "a") as handle:  # as a later version might write it
        handle.attrs["measures"] = np.array(["SL", "VKL", "FUTURE"], dtype=h5py.string_dtype())
        handle.attrs["higher_is_better"] = np.array([True, False, True])
    with open_dataset(copy) as dataset:
        assert dataset.measures == ("SL", "VKL", "FUTURE")
        assert dataset[0]["quality"].shape == (N_VIEWS, 3)
        with pytest.raises(InputError) as caught:
            dataset.higher_is_better
    assert str(caught.value).startswith("dataset.h5: measure 'FUTURE' is not one this "
                                        "vptoolkit knows")
    assert "\n" not in str(caught.value)
