"""Networks that read the features a bare cloud carries (``spacing_area``,
``estimated_normal``): trained on a store of clouds, answering point files, clouds and meshes
from the points alone, whatever the file's name or format."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.networks import TINY_CONFIG, calibrated
from vptoolkit.io import load, load_mesh
from vptoolkit.point_features import CLOUD_FEATURES, point_features, turn_features
from vptoolkit.points import sample_surface
from vptoolkit.rotations import random_rotation
from vptoolkit.samples import sample_path

require_package("torch")

from vptoolkit.learn.model import ViewpointNet, save_model  # noqa: E402
from vptoolkit.learn.predict import MeshPredictor, cloud_surface, predict  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_thread")

CLOUD_CONFIG = dataclasses.replace(TINY_CONFIG, point_features=CLOUD_FEATURES)
"""The tests' tiny network, reading each point's spacing area and estimated normal."""
INPUT = {"n_points": 512, "n_fps": 128}


def surface(name: str, n: int, seed: int) -> np.ndarray:
    return sample_surface(load_mesh(sample_path(name)), n, seed=seed).points


@pytest.fixture(scope="module")
def checkpoint(one_thread: None, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The untrained cloud-feature network, calibrated on four samples' clouds, saved."""
    clouds = []
    for name in ("teapot.stl", "mug.obj", "bunny.ply", "suzanne.ply"):
        points = surface(name, 2048, seed=1)
        clouds.append(np.column_stack([points, point_features(points, CLOUD_FEATURES)]))
    network = calibrated(ViewpointNet(CLOUD_CONFIG, seed=0), np.stack(clouds))
    path = tmp_path_factory.mktemp("cloud_net") / "net.safetensors"
    save_model(network, path, metadata={"input": INPUT})
    return path


def test_a_point_file_feeds_the_network_its_own_features(checkpoint, tmp_path):
    points = surface("bunny.ply", 4000, seed=0)
    np.save(tmp_path / "a.npy", points.astype(np.float32))
    np.save(tmp_path / "zebra.npy", points.astype(np.float32))
    answers = predict(checkpoint, [tmp_path / "a.npy", tmp_path / "zebra.npy"], device="cpu")
    assert answers.directions.shape == (2, len(CLOUD_CONFIG.measures), 3)
    np.testing.assert_allclose(np.linalg.norm(answers.directions, axis=-1), 1.0, rtol=1e-6)
    np.testing.assert_array_equal(answers.directions[0], answers.directions[1])  # renamed


def test_a_cloud_carries_its_features_and_the_predictor_answers_it(checkpoint, tmp_path):
    path = tmp_path / "bunny.npy"
    np.save(path, surface("bunny.ply", 3000, seed=2).astype(np.float32))
    cloud = load(path)
    points, features = cloud_surface(cloud, CLOUD_FEATURES)
    assert features is not None and features.shape == (3000, 4)
    np.testing.assert_array_equal(features, point_features(points, CLOUD_FEATURES))
    answer = MeshPredictor(checkpoint, n_inputs=2)(cloud)
    assert answer.shape == (len(CLOUD_CONFIG.measures), 3)
    np.testing.assert_allclose(answer, predict(checkpoint, path, n_inputs=2).directions[0],
                               atol=1e-6)


def test_a_mesh_gets_the_features_of_its_surface_sample(checkpoint):
    mesh = load_mesh(sample_path("mug.obj"))
    answer = MeshPredictor(checkpoint, n_inputs=1)(mesh)
    np.testing.assert_allclose(np.linalg.norm(answer, axis=-1), 1.0, rtol=1e-6)


def test_the_estimated_normals_turn_with_a_turned_cloud():
    points = surface("teapot.stl", 3000, seed=3)
    rotation = random_rotation(np.random.default_rng(4))
    np.testing.assert_allclose(
        point_features(points @ rotation.T, CLOUD_FEATURES),
        turn_features(point_features(points, CLOUD_FEATURES), CLOUD_FEATURES, rotation.T),
        atol=1e-4)


def test_the_protocol_predictor_needs_no_dataset_for_cloud_features(checkpoint):
    from vptoolkit.learn.predict import network_predictor
    from vptoolkit.point_cloud import PointCloud

    points = surface("teapot.stl", 3000, seed=5)
    answer = network_predictor(checkpoint, n_inputs=2, device="cpu")([points], ["teapot"])
    expected = MeshPredictor(checkpoint, n_inputs=2)(PointCloud(points, name="teapot"))
    np.testing.assert_allclose(answer[0], expected, atol=1e-6)
