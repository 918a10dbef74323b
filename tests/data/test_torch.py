"""The torch adapter: paper-style inputs, consistent rotations, seeded per model."""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import REQUIRE_ALL
from fixtures.stores import MODELS, N_VIEWS, synthetic_entries, write_synthetic
from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.errors import InputError
from vptoolkit.optional import is_available
from vptoolkit.sphere import nearest_view

if not is_available("torch") and not REQUIRE_ALL:  # with REQUIRE_ALL the import below fails
    pytest.skip("torch not installed", allow_module_level=True)
import torch  # noqa: E402

from vptoolkit.data.torch import ViewpointTorchDataset  # noqa: E402
from vptoolkit.rotations import model_key, random_rotation  # noqa: E402

N_SURFACE = 2000  # enough for the paper's 1024 farthest points


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ViewpointDataset]:
    folder = tmp_path_factory.mktemp("torch")
    store = write_synthetic(folder / "dataset.zarr.zip", synthetic_entries(n_points=N_SURFACE))
    with open_dataset(store) as opened:
        yield opened


def test_items_have_the_documented_shapes_and_dtypes(dataset: ViewpointDataset) -> None:
    adapter = ViewpointTorchDataset(dataset)  # the paper's 4096 = 1024 FPS + 3072 random
    assert isinstance(adapter, torch.utils.data.Dataset) and len(adapter) == len(MODELS)
    item = adapter[0]
    expected = {"points": ((4096, 3), torch.float32), "views": ((N_VIEWS, 3), torch.float32),
                "quality": ((N_VIEWS, 4), torch.float32), "best_views": ((4, 3), torch.float32),
                "best_index": ((4,), torch.int64), "rotation": ((3, 3), torch.float32)}
    assert set(item) == {*expected, "name", "category", "label"}
    for key, (shape, dtype) in expected.items():
        assert tuple(item[key].shape) == shape and item[key].dtype == dtype, key
    assert (item["name"], item["category"], item["label"]) == ("airplane_0001", "airplane", 0)
    assert (adapter[4]["category"], adapter[4]["label"]) == ("chair", 1)
    rotation = item["rotation"].double().numpy()
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-6)
    assert np.linalg.det(rotation) == pytest.approx(1.0, abs=1e-6)


def test_points_are_farthest_points_then_random_surface_points(dataset: ViewpointDataset) -> None:
    adapter = ViewpointTorchDataset(dataset, n_points=600, n_fps=100, rotate=False, seed=5)
    item = adapter[2]
    surface = dataset[2]["points"]
    points = item["points"].numpy()
    assert np.array_equal(item["rotation"].numpy(), np.eye(3, dtype=np.float32))
    index = nearest_rows(points, surface)
    np.testing.assert_array_equal(points, surface[index])  # taken from the stored sample
    assert len(np.unique(index)) == 600  # 2000 points suffice: no repeats


def nearest_rows(points: np.ndarray, surface: np.ndarray) -> np.ndarray:
    distance = ((points[:, None, :] - surface[None, :, :]) ** 2).sum(axis=2)
    return distance.argmin(axis=1)


def test_points_and_views_share_one_rotation(dataset: ViewpointDataset) -> None:
    rotated = ViewpointTorchDataset(dataset, n_points=512, n_fps=128, seed=11)
    plain = ViewpointTorchDataset(dataset, n_points=512, n_fps=128, rotate=False, seed=11)
    for index in range(len(dataset)):
        a, b = rotated[index], plain[index]
        rotation = a["rotation"].double().numpy()
        assert not np.allclose(rotation, np.eye(3), atol=1e-2)
        np.testing.assert_allclose(a["points"].numpy(), b["points"].numpy() @ rotation.T, atol=1e-4)
        np.testing.assert_allclose(a["views"].numpy(), dataset.views @ rotation.T, atol=1e-6)
        best = dataset[index]["best_index"]
        np.testing.assert_allclose(a["best_views"].numpy(), dataset.views[best] @ rotation.T,
                                   atol=1e-6)
        np.testing.assert_array_equal(a["quality"].numpy(), dataset[index]["quality"])


def test_rotated_best_view_keeps_its_quality(dataset: ViewpointDataset) -> None:
    adapter = ViewpointTorchDataset(dataset, n_points=256, n_fps=64, seed=3)
    for index in range(len(dataset)):
        item = adapter[index]
        rotation = item["rotation"].double().numpy()
        best_views = item["best_views"].double().numpy()
        back = best_views @ rotation  # undo v -> R v
        quality = dataset.quality_of(item["name"], back)
        np.testing.assert_array_equal(np.diag(quality), np.ones(4, dtype=np.float32))
        np.testing.assert_array_equal(nearest_view(back, dataset.views), item["best_index"].numpy())
        # and in the rotated frame the best view is still the nearest of the rotated views
        np.testing.assert_array_equal(
            nearest_view(best_views, item["views"].double().numpy()), item["best_index"].numpy())


def _same(a: dict, b: dict) -> bool:
    return all(torch.equal(a[key], b[key]) if isinstance(a[key], torch.Tensor) else a[key] == b[key]
               for key in a)


def test_items_are_deterministic_per_seed_epoch_and_model(dataset: ViewpointDataset) -> None:
    options = {"n_points": 300, "n_fps": 50}
    first = ViewpointTorchDataset(dataset, seed=1, **options)
    again = ViewpointTorchDataset(dataset, seed=1, **options)
    other = ViewpointTorchDataset(dataset, seed=2, **options)
    assert _same(first[3], again[3]) and _same(first[3], first[3])
    assert not torch.equal(first[3]["points"], other[3]["points"])
    assert not torch.equal(first[3]["rotation"], other[3]["rotation"])
    first.set_epoch(1)
    assert not torch.equal(first[3]["rotation"], again[3]["rotation"])
    first.set_epoch(0)
    assert _same(first[3], again[3])
    # Randomness follows the model, not its position: the same model in a split matches.
    train = ViewpointTorchDataset(dataset.split("train"), seed=1, **options)
    assert train[1]["name"] == "chair_0001" and _same(train[1], first[3])
    assert not torch.equal(first[3]["rotation"], first[4]["rotation"])


def test_random_rotation_is_uniform() -> None:
    rng = np.random.default_rng(0)
    rotations = np.stack([random_rotation(rng) for _ in range(4000)])
    np.testing.assert_allclose(rotations @ rotations.transpose(0, 2, 1),
                               np.broadcast_to(np.eye(3), rotations.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(rotations), 1.0, atol=1e-12)
    # Haar measure: every entry has mean 0 and variance 1/3.
    assert np.abs(rotations.mean(axis=0)).max() < 0.05
    np.testing.assert_allclose((rotations**2).mean(axis=0), 1 / 3, atol=0.03)
    with pytest.raises(InputError, match="rng: expected a numpy.random.Generator"):
        random_rotation(0)  # type: ignore[arg-type]


def test_model_key_is_stable() -> None:
    assert model_key("airplane_0001") == model_key("airplane_0001") != model_key("airplane_0002")
    assert 0 <= model_key("x") < 2**64


def test_data_loader_batches_and_workers(dataset: ViewpointDataset) -> None:
    adapter = ViewpointTorchDataset(dataset, n_points=128, n_fps=32, seed=4)
    serial = list(torch.utils.data.DataLoader(adapter, batch_size=2))
    assert serial[0]["points"].shape == (2, 128, 3) and serial[0]["name"] == [
        "airplane_0001", "airplane_0002"]
    parallel = list(torch.utils.data.DataLoader(adapter, batch_size=2, num_workers=2))
    assert len(parallel) == len(serial) == 3
    for a, b in zip(serial, parallel):
        assert _same(a, b)


def test_persistent_workers_follow_set_epoch(dataset: ViewpointDataset) -> None:
    adapter = ViewpointTorchDataset(dataset, n_points=128, n_fps=32, seed=4)
    loader = torch.utils.data.DataLoader(adapter, batch_size=len(MODELS), num_workers=1,
                                         persistent_workers=True)
    rotations = []
    for epoch in (0, 1, 2, 1):
        adapter.set_epoch(epoch)
        (batch,) = list(loader)
        assert adapter.epoch == epoch
        here = torch.stack([adapter[index]["rotation"] for index in range(len(MODELS))])
        assert torch.equal(batch["rotation"], here)  # the worker used this epoch
        assert batch["label"].tolist() == [0, 0, 0, 1, 1]
        rotations.append(batch["rotation"])
    assert not torch.equal(rotations[0], rotations[1])
    assert not torch.equal(rotations[1], rotations[2])
    assert torch.equal(rotations[1], rotations[3])  # deterministic per epoch


def test_transform_sees_the_augmented_item(dataset: ViewpointDataset) -> None:
    plain = ViewpointTorchDataset(dataset, n_points=128, n_fps=32, seed=4)
    scaled = ViewpointTorchDataset(dataset, n_points=128, n_fps=32, seed=4,
                                   transform=lambda item: {**item, "points": item["points"] * 2})
    assert torch.equal(scaled[2]["points"], plain[2]["points"] * 2)
    assert torch.equal(scaled[2]["rotation"], plain[2]["rotation"])
    only_label = ViewpointTorchDataset(dataset, n_points=128, n_fps=32,
                                       transform=lambda item: (item["points"], item["label"]))
    points, label = only_label[3]
    assert points.shape == (128, 3) and label == 1
    with pytest.raises(InputError, match="transform: expected a callable"):
        ViewpointTorchDataset(dataset, transform=3)  # type: ignore[arg-type]


@pytest.mark.parametrize(("options", "message"), [
    ({"n_fps": 200, "n_points": 100}, "n_fps: 200 exceeds n_points=100"),
    ({"n_points": 0}, "n_points: expected at least 1"),
    ({"seed": -1}, "seed: expected a non-negative integer"),
], ids=["fps-above-points", "no-points", "negative-seed"])
def test_bad_options(dataset: ViewpointDataset, options: dict, message: str) -> None:
    with pytest.raises(InputError, match=message):
        ViewpointTorchDataset(dataset, **options)


def test_too_few_surface_points_for_fps(tmp_path: Path) -> None:
    store = write_synthetic(tmp_path / "small.h5", synthetic_entries(MODELS[:1], n_points=200))
    with open_dataset(store) as small:
        with pytest.raises(InputError, match="fewer than the n_fps=1024"):
            ViewpointTorchDataset(small)[0]


# --------------------------------------------------------------------------- as PyTorch Geometric


@pytest.mark.parametrize("index", [
    slice(1, 4), [1, 2, 3], (1, 2, 3), np.array([1, 2, 3]), torch.tensor([1, 2, 3]),
    np.array([False, True, True, True, False]), torch.tensor([False, True, True, True, False]),
], ids=["slice", "list", "tuple", "array", "tensor", "mask", "tensor-mask"])
def test_slices_and_index_lists_give_a_dataset_over_those_models(
        dataset: ViewpointDataset, index: object) -> None:
    adapter = ViewpointTorchDataset(dataset, n_points=128, n_fps=32, seed=4)
    picked = adapter[index]
    assert isinstance(picked, ViewpointTorchDataset) and len(picked) == 3
    assert [picked[i]["name"] for i in range(3)] == dataset.names[1:4]
    assert (picked.n_points, picked.n_fps, picked.seed) == (128, 32, 4)
    for position, model in enumerate(range(1, 4)):  # the same items as through the whole dataset
        assert _same(picked[position], adapter[model])


def test_a_subset_keeps_the_order_of_its_indices_and_an_epoch_of_its_own(
        dataset: ViewpointDataset) -> None:
    adapter = ViewpointTorchDataset(dataset, n_points=128, n_fps=32, seed=4, fps_pool=2)
    adapter.set_epoch(3)
    picked = adapter[[4, 0, -1]]
    assert [picked[i]["name"] for i in range(3)] == ["chair_0002", "airplane_0001", "chair_0002"]
    assert picked.epoch == 3 and _same(picked[0], adapter[4]) and _same(picked[1], adapter[0])
    picked.set_epoch(5)
    assert (picked.epoch, adapter.epoch) == (5, 3)
    assert isinstance(adapter[torch.tensor(2)], dict)  # a 0-d tensor is one item
    assert len(adapter[2:2]) == 0 and len(adapter[[]]) == 0
    with pytest.raises(IndexError, match="index 5 out of range for 5 models"):
        adapter[[0, 5]]


def test_split_selects_the_models_of_one_split(dataset: ViewpointDataset) -> None:
    train = ViewpointTorchDataset(dataset, split="train", n_points=128, n_fps=32)
    assert len(train) == 3
    assert [train[i]["name"] for i in range(3)] == dataset.split("train").names
    with pytest.warns(UserWarning):
        validation = ViewpointTorchDataset(dataset, split="val", n_points=128, n_fps=32)
    assert [validation[0]["name"]] == dataset.split("validation").names == ["airplane_0003"]
    with pytest.raises(InputError, match="split: unknown split 'dev'"):
        ViewpointTorchDataset(dataset, split="dev")


def test_num_classes_and_class_names_are_the_stores_in_every_split(
        dataset: ViewpointDataset) -> None:
    adapter = ViewpointTorchDataset(dataset)
    assert (adapter.num_classes, adapter.class_names) == (2, ["airplane", "chair"])
    with pytest.warns(UserWarning):
        test = ViewpointTorchDataset(dataset, split="test")
    assert len(test) == 1 and (test.num_classes, test.class_names) == (2, ["airplane", "chair"])
    assert adapter[0:1].num_classes == 2
    assert test.class_names[test[0]["label"]] == test[0]["category"]


def test_a_category_without_models_in_the_split_is_one_warning_line(
        dataset: ViewpointDataset) -> None:
    with pytest.warns(UserWarning) as caught:
        ViewpointTorchDataset(dataset, split="val")
    assert [str(w.message) for w in caught] == [
        "category 'chair' has no model in split 'validation'"]
    assert caught[0].filename == __file__  # points at the caller
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ViewpointTorchDataset(dataset, split="train")  # every category has train models
        ViewpointTorchDataset(dataset.split("validation"), split="validation")  # only airplanes


def test_a_path_is_opened_as_the_root_of_the_adapter(dataset: ViewpointDataset) -> None:
    """As PyTorch Geometric's root: the path of a store gives the same items as the opened one."""
    by_path = ViewpointTorchDataset(str(dataset.path), split="train", n_points=128, n_fps=32)
    opened = ViewpointTorchDataset(dataset, split="train", n_points=128, n_fps=32)
    assert len(by_path) == len(opened) == 3
    assert np.array_equal(by_path[0]["points"], opened[0]["points"])
    assert by_path[1]["name"] == opened[1]["name"]
    with pytest.raises(InputError, match="expected a ViewpointDataset or the path or URL"):
        ViewpointTorchDataset(42)  # type: ignore[arg-type]
