"""The evaluation protocol: fixed rotations, scoring under rotation, baselines, standard errors."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from fixtures.builds import THREE_MEASURES, THREE_MESHES, build_samples
from fixtures.environment import require_package
from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.errors import InputError
from vptoolkit.evaluate.protocol import (
    ProtocolScores,
    best_constant_directions,
    constant_predictor,
    paired_difference,
    pca_predictor,
    random_view_scores,
    score_mesh_protocol,
    score_protocol,
)
from vptoolkit.rotations import fixed_rotations, model_key, random_rotation
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import nearest_view

require_package("zarr")

MESHES = ("bunny", "mug", "table", "teapot")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ViewpointDataset]:
    """Four bundled meshes measured from 1000 views at 48 px (enough for a random-view check)."""
    options = BuildOptions(MeasureSettings(views=1000, resolution=48), n_points=3000,
                           clean=False)
    out = build_samples(tmp_path_factory.mktemp("protocol"), MESHES, category="things",
                        options=options)
    with open_dataset(out) as opened:
        yield opened


def test_fixed_rotations_are_proper_seeded_by_name_and_prefix_stable():
    rotations = fixed_rotations("bunny", 5)
    assert rotations.shape == (5, 3, 3)
    assert np.allclose(rotations @ rotations.transpose(0, 2, 1), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(rotations), 1.0)
    assert np.array_equal(fixed_rotations("bunny", 3), rotations[:3])
    assert not np.allclose(fixed_rotations("mug", 5), rotations)
    assert not np.allclose(fixed_rotations("bunny", 5, seed=1), rotations)
    assert model_key("bunny") == model_key("bunny") != model_key("mug")
    with pytest.raises(InputError, match="count"):
        fixed_rotations("bunny", 0)
    with pytest.raises(InputError, match="rng"):
        random_rotation(0)  # type: ignore[arg-type]


def test_an_equivariant_predictor_scores_alike_rotated_or_not(dataset):
    """The PCA axis turns with the model, so rotations keep its score; a constant's changes."""
    rotated = score_protocol(dataset, pca_predictor, n_rotations=3)
    stored = score_protocol(dataset, pca_predictor, rotate=False)
    assert rotated.n_rotations == 3 and stored.n_rotations == 0
    assert np.allclose(rotated.scores, stored.scores, atol=1e-9)
    constant = constant_predictor(np.tile([0.0, 0.0, 1.0], (4, 1)))
    assert not np.allclose(score_protocol(dataset, constant, n_rotations=3).scores,
                           score_protocol(dataset, constant, rotate=False).scores)


def test_predictions_are_rotated_back_before_scoring(dataset):
    """A predictor answering the best view in each known rotated frame scores 100 %."""
    best = {name: dataset.views[dataset[i]["best_index"]] for i, name in enumerate(dataset.names)}
    turns = {name: fixed_rotations(name, 2) for name in dataset.names}
    calls = {"n": 0}

    def oracle(points, names):
        k = calls["n"]
        calls["n"] += 1
        return np.stack([best[name] @ turns[name][k].T for name in names])

    scores = score_protocol(dataset, oracle, n_rotations=2)
    assert calls["n"] == 2 and np.allclose(scores.scores, 100.0)


def test_mesh_answers_see_the_stored_mesh_under_the_same_rotations(dataset):
    """An answer that draws the mesh is scored like a point predictor: same rotations, same
    rotation back; the PCA axis of the rotated mesh's vertices turns with it."""
    constant = np.tile([0.0, 0.0, 1.0], (4, 1))
    by_mesh = score_mesh_protocol(dataset, lambda mesh: constant, n_rotations=3)
    by_points = score_protocol(dataset, constant_predictor(constant), n_rotations=3)
    assert by_mesh.n_rotations == 3 and np.allclose(by_mesh.scores, by_points.scores)
    seen = []

    def answer(mesh):
        seen.append(mesh.vertices.copy())
        return np.tile(pca_predictor([mesh.vertices], [mesh.name])[0][0], (4, 1))

    score_mesh_protocol(dataset, answer, n_rotations=2)
    vertices, _ = dataset.mesh(0)
    first = fixed_rotations(dataset.names[0], 2)[0]
    assert np.allclose(seen[0], np.asarray(vertices, dtype=np.float64) @ first.T)
    with pytest.raises(InputError, match="answer: expected directions"):
        score_mesh_protocol(dataset, lambda mesh: np.zeros(3))


def test_random_view_expectation_matches_many_random_directions(dataset):
    expected = random_view_scores(dataset)
    rng = np.random.default_rng(0)
    directions = rng.standard_normal((20000, 3))
    for i in range(len(dataset)):
        quality = dataset[i]["quality"][nearest_view(directions, dataset.views)]
        assert np.allclose(100.0 * quality.mean(axis=0), expected.scores[i], atol=1.0)


def test_best_constant_direction_is_the_best_mean_view(dataset):
    directions = best_constant_directions(dataset)
    total = sum(dataset[i]["quality"] for i in range(len(dataset)))
    assert np.array_equal(directions, dataset.views[total.argmax(axis=0)])
    stored = score_protocol(dataset, constant_predictor(directions), rotate=False)
    assert np.allclose(stored.mean, 100.0 * total.max(axis=0) / len(dataset), atol=1e-4)


def test_means_standard_errors_and_paired_differences():
    scores = np.array([[10.0, 20, 30, 40], [20, 20, 50, 40], [30, 20, 40, 40]])
    first = ProtocolScores(("a", "b", "c"), ("x", "x", "y"), scores, 2)
    assert np.allclose(first.mean, [20, 20, 40, 40])
    assert np.allclose(first.sem, [10 / np.sqrt(3), 0, 10 / np.sqrt(3), 0])
    assert np.allclose(first.category_means()["x"], [15, 20, 40, 40])
    second = ProtocolScores(("a", "b", "c"), ("x", "x", "y"), scores - [1, 2, 3, 4], 2)
    delta, sem = paired_difference(first, second)
    assert np.allclose(delta, [1, 2, 3, 4]) and np.allclose(sem, 0)
    other = ProtocolScores(("a", "b", "d"), ("x", "x", "y"), scores, 2)
    with pytest.raises(InputError, match="different models"):
        paired_difference(first, other)


def test_bad_predictors_and_empty_inputs_are_refused(dataset, tmp_path):
    with pytest.raises(InputError, match=r"predictor: expected directions of shape \(4, 4, 3\)"):
        score_protocol(dataset, lambda points, names: np.zeros((len(names), 3)))
    with pytest.raises(InputError, match="directions: expected shape"):
        constant_predictor(np.zeros(3))
    with pytest.raises(InputError, match="dataset: expected a ViewpointDataset"):
        score_protocol(Path("nowhere"), pca_predictor)  # type: ignore[arg-type]


def test_the_protocol_scores_every_recorded_measure(three_dataset):
    expected = random_view_scores(three_dataset)
    assert expected.measures == THREE_MEASURES
    assert expected.scores.shape == (len(THREE_MESHES), 3)
    qualities = np.stack([three_dataset[i]["quality"] for i in range(len(three_dataset))])
    np.testing.assert_allclose(expected.scores, 100.0 * qualities.mean(axis=1), rtol=1e-6)
    rotated = score_protocol(three_dataset, pca_predictor, n_rotations=2)
    stored = score_protocol(three_dataset, pca_predictor, rotate=False)
    assert rotated.measures == THREE_MEASURES
    assert rotated.scores.shape == (len(THREE_MESHES), 3)
    np.testing.assert_allclose(rotated.scores, stored.scores, atol=1e-9)  # PCA turns along
    constant = best_constant_directions(three_dataset)
    assert constant.shape == (3, 3)
    total = qualities.sum(axis=0)
    np.testing.assert_array_equal(constant, three_dataset.views[total.argmax(axis=0)])
    upright = score_protocol(three_dataset, constant_predictor(constant), rotate=False)
    np.testing.assert_allclose(upright.mean, 100.0 * total.max(axis=0) / len(three_dataset),
                               atol=1e-4)
    by_mesh = score_mesh_protocol(three_dataset, lambda mesh: constant, n_rotations=2)
    by_points = score_protocol(three_dataset, constant_predictor(constant), n_rotations=2)
    np.testing.assert_allclose(by_mesh.scores, by_points.scores)
    delta, sem = paired_difference(upright, stored)
    assert delta.shape == sem.shape == (3,)
    with pytest.raises(InputError, match=r"predictor: expected directions of shape \(4, 3, 3\)"):
        score_protocol(three_dataset, lambda points, names: np.zeros((len(names), 4, 3)))
