"""The light loader and the torch adapter over a store of three measures, and over one that
records a measure this vptoolkit does not know."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.stores import BUILD, N_VIEWS, synthetic_entries, write_synthetic
from vptoolkit.errors import InputError

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
