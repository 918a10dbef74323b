"""Baseline directions: random, PCA and the oracle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fixtures.builds import THREE_MESHES
from fixtures.stores import SCORED_ENTRIES
from vptoolkit.data import ViewpointDataset
from vptoolkit.errors import InputError
from vptoolkit.evaluate.baselines import oracle_directions, pca_directions, random_directions
from vptoolkit.evaluate.scores import score_directions


def test_random_directions() -> None:
    directions = random_directions(2000, seed=5)
    assert directions.shape == (2000, 4, 3) and directions.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(directions, axis=2), 1.0)
    np.testing.assert_array_equal(directions, random_directions(2000, seed=5))
    assert not np.allclose(directions, random_directions(2000, seed=6))
    # uniform on the sphere: mean ~ 0, each coordinate's second moment ~ 1/3
    flat = directions.reshape(-1, 3)
    np.testing.assert_allclose(flat.mean(axis=0), 0.0, atol=4 / math.sqrt(3 * len(flat)))
    np.testing.assert_allclose((flat**2).mean(axis=0), 1 / 3, atol=0.02)
    assert random_directions(0, seed=0).shape == (0, 4, 3)
    with pytest.raises(InputError, match="n: "):
        random_directions(-1, seed=0)
    with pytest.raises(InputError, match="seed: "):
        random_directions(3, seed=None)  # type: ignore[arg-type]


def _rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _table_cloud(seed: int) -> np.ndarray:
    """A 4 x 2 table top at z = 0.5 with four legs down to z = -0.5 (axes 4 > 2 > 1)."""
    rng = np.random.default_rng(seed)
    top = np.column_stack([rng.uniform(-2, 2, 3000), rng.uniform(-1, 1, 3000), np.full(3000, 0.5)])
    legs = np.concatenate([
        np.column_stack([np.full(150, x), np.full(150, y), rng.uniform(-0.5, 0.5, 150)])
        for x in (-1.9, 1.9) for y in (-0.9, 0.9)
    ])
    return np.concatenate([top, legs])


def test_pca_views_a_table_from_the_top_and_rotates_with_it() -> None:
    table = _table_cloud(0)
    direction = pca_directions(table[None])[0]
    assert direction.shape == (4, 3)
    np.testing.assert_allclose(direction, np.tile([0.0, 0.0, 1.0], (4, 1)), atol=0.01)
    rotations = [_rotation(seed) for seed in range(3)]
    rotated = pca_directions([table @ rotation.T for rotation in rotations])
    for rotation, predicted in zip(rotations, rotated):
        np.testing.assert_allclose(predicted[0], rotation @ direction[0], atol=1e-9)


def test_pca_is_deterministic_and_unit(scored_dataset: ViewpointDataset) -> None:
    clouds = [scored_dataset[i]["points"] for i in range(len(scored_dataset))]
    directions = pca_directions(clouds)
    assert directions.shape == (len(scored_dataset), 4, 3) and directions.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(directions, axis=2), 1.0)
    np.testing.assert_array_equal(directions, pca_directions(np.stack(clouds)))
    np.testing.assert_array_equal(directions, directions[:, :1].repeat(4, axis=1))
    # a symmetric cloud uses the fallback: largest component positive
    box = np.array([[x, y, z] for x in (-2, 2) for y in (-1, 1) for z in (-0.5, 0.5)], float)
    np.testing.assert_allclose(pca_directions([box @ _rotation(4).T])[0, 0],
                               np.sign(_rotation(4)[np.argmax(abs(_rotation(4)[:, 2])), 2])
                               * _rotation(4)[:, 2], atol=1e-9)
    report = score_directions(scored_dataset, directions)
    assert np.isfinite(report.scores).all()


@pytest.mark.parametrize("points, message", [
    (np.ones((2, 10, 2)), "expected (n_models, n_points, 3)"),
    (np.ones((10, 3)), "expected (n_models, n_points, 3)"),
    ([np.ones((10, 3))], "points[0]: all points coincide"),
    ([_table_cloud(0), np.ones((2, 3))], "points[1]: needs at least 3 points"),
    ([np.full((5, 3), np.nan)], "points[0]: contains NaN"),
    ([np.ones((5, 4))], "points[0]: expected shape (n_points, 3)"),
], ids=["last-axis", "single-cloud", "coincident", "too-few", "nan", "list-shape"])
def test_pca_rejects_bad_clouds(points: object, message: str) -> None:
    with pytest.raises(InputError) as caught:
        pca_directions(points)  # type: ignore[arg-type]
    assert message in str(caught.value)


def test_oracle_directions_are_the_stored_best_views(scored_dataset: ViewpointDataset) -> None:
    oracle = oracle_directions(scored_dataset)
    for entry, row in zip(SCORED_ENTRIES, oracle):
        np.testing.assert_array_equal(row, scored_dataset.views[entry.best_index])


def test_baselines_give_one_direction_per_recorded_measure(three_dataset):
    random = random_directions(len(three_dataset), seed=0, n_measures=3)
    assert random.shape == (len(THREE_MESHES), 3, 3)
    np.testing.assert_allclose(np.linalg.norm(random, axis=2), 1.0)
    assert np.isfinite(score_directions(three_dataset, random).scores).all()
    clouds = [three_dataset[i]["points"] for i in range(len(three_dataset))]
    pca = pca_directions(clouds, n_measures=3)
    assert pca.shape == (len(THREE_MESHES), 3, 3)
    np.testing.assert_array_equal(pca, pca[:, :1].repeat(3, axis=1))
    with pytest.raises(InputError, match="n_measures"):
        random_directions(2, seed=0, n_measures=0)
