"""Point features in the network's inputs: the configuration, the network, the torch dataset,
prediction from meshes and datasets, and the best-view prior."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.networks import TINY_CONFIG, calibrated
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.point_features import face_area_feature
from vptoolkit.points import N_SURFACE_POINTS, sample_surface
from vptoolkit.samples import sample_path

require_package("torch")
require_package("safetensors")
require_package("zarr")

import torch  # noqa: E402

from vptoolkit.data import open_dataset  # noqa: E402
from vptoolkit.data.torch import ViewpointTorchDataset  # noqa: E402
from vptoolkit.learn.config import ModelConfig  # noqa: E402
from vptoolkit.learn.draws import network_indices, network_inputs, network_points  # noqa: E402
from vptoolkit.learn.frame import canonical_frame  # noqa: E402
from vptoolkit.learn.model import ViewpointNet, load_model, save_model  # noqa: E402
from vptoolkit.learn.predict import (  # noqa: E402
    MeshPredictor,
    network_predictor,
    predict,
    predict_directions,
)
from vptoolkit.learn.prior import NetworkPrior  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_thread")

FACE_AREA = ("face_area",)
FACE_AREA_CONFIG = dataclasses.replace(TINY_CONFIG, point_features=FACE_AREA)
"""The tests' tiny network, reading each point's face area after its coordinates."""
INPUT = {"n_points": 512, "n_fps": 128}
"""The input size the saved network says it was trained at (predictors use it)."""


def surface_cloud(name: str, n: int, seed: int) -> np.ndarray:
    """(n, 4): points sampled on a bundled mesh and the face area feature of each."""
    mesh = load_mesh(sample_path(name))
    sample = sample_surface(mesh, n, seed=seed)
    return np.column_stack([sample.points, face_area_feature(mesh, sample.face_index)])


@pytest.fixture(scope="module")
def network(one_thread: None) -> ViewpointNet:
    """The untrained face-area network, its batch norms set to the statistics of four sample
    meshes' clouds (:func:`calibrated`)."""
    clouds = np.stack([surface_cloud(name, 2048, seed=1)
                       for name in ("teapot.stl", "mug.obj", "bunny.ply", "suzanne.ply")])
    return calibrated(ViewpointNet(FACE_AREA_CONFIG, seed=0), clouds)


@pytest.fixture(scope="module")
def cloud() -> torch.Tensor:
    """(2048, 4): points of the teapot, whose faces differ in size a lot, and their feature."""
    points = surface_cloud("teapot.stl", 2048, seed=0)
    assert points[:, 3].std() > 0.3
    return torch.from_numpy(points.astype(np.float32))


@pytest.fixture(scope="module")
def checkpoint(network: ViewpointNet, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``network`` saved, trained (it says) on 512-point inputs."""
    path = tmp_path_factory.mktemp("face_area_net") / "net.safetensors"
    save_model(network, path, metadata={"input": INPUT})
    return path


@pytest.fixture(scope="module")
def dataset_dir(features_dataset: Path) -> Path:
    """The mug and the teapot, 1000 stored points each (``features_dataset``)."""
    return features_dataset


def answers(model: ViewpointNet, clouds: torch.Tensor) -> torch.Tensor:
    with torch.no_grad():
        return model(clouds)["directions"]


# the configuration


def test_the_configuration_counts_and_stores_its_point_features():
    config = ModelConfig(point_features=FACE_AREA)
    assert config.point_features == FACE_AREA and config.input_channels == 4
    assert ModelConfig().point_features == () and ModelConfig().input_channels == 3
    stored = config.to_dict()
    assert stored["point_features"] == ["face_area"]
    assert ModelConfig.from_dict(json.loads(json.dumps(stored))) == config
    older = {key: value for key, value in stored.items() if key != "point_features"}
    assert ModelConfig.from_dict(older).point_features == ()


@pytest.mark.parametrize("names", [("curvature",), ("face_area", "face_area"), "face_area"])
def test_the_configuration_refuses_bad_feature_names(names):
    with pytest.raises(InputError, match="^point_features: "):
        ModelConfig(point_features=names)
    with pytest.raises(InputError, match="point_features: "):
        ModelConfig.from_dict({"point_features": names})


def test_a_checkpoint_that_names_no_point_features_reads_coordinates_alone(tmp_path):
    path = tmp_path / "plain.safetensors"
    _, config_path = save_model(ViewpointNet(TINY_CONFIG), path)
    written = json.loads(config_path.read_text())
    del written["architecture"]["point_features"]  # as a checkpoint from before the features
    config_path.write_text(json.dumps(written))
    model, _ = load_model(path)
    assert model.config.point_features == () and model.config.input_channels == 3


# the network


def test_permuting_points_with_their_features_changes_no_answer(network, cloud):
    """The features are gathered in the order the hierarchy sorts the points into."""
    order = torch.from_numpy(np.random.default_rng(0).permutation(len(cloud)))
    alone = answers(network, cloud[None])
    np.testing.assert_allclose(answers(network, cloud[order][None]), alone, atol=1e-5)
    together = answers(network, torch.stack([cloud, cloud[order]]))  # each cloud its own order
    np.testing.assert_allclose(together, alone.expand(2, -1, -1), atol=1e-5)
    # the features travel with their points: shuffled alone, they give another answer
    shuffled = torch.cat([cloud[:, :3], cloud[order, 3:]], dim=1)
    assert (answers(network, shuffled[None]) - alone).abs().max() > 0.1


def test_the_feature_column_alone_changes_the_answer(network, cloud):
    flat = cloud.clone()
    flat[:, 3] = 0.0  # every face of mean area
    assert (answers(network, flat[None]) - answers(network, cloud[None])).abs().max() > 0.1


def test_coordinates_alone_are_refused_with_the_expected_shape(network, cloud):
    with pytest.raises(InputError, match=r"expected shape \(B, N, 4\) with B, N >= 1, "
                                         r"got \(1, 2048, 3\)"):
        network(cloud[None, :, :3])
    with pytest.raises(InputError, match=r"expected shape \(n_models, n_points, 4\)"):
        predict_directions(network, cloud[None, :, :3].numpy())


def test_forward_in_frames_reads_points_with_features(network, cloud):
    frames = torch.stack([torch.eye(3), torch.diag(torch.tensor([1.0, -1.0, -1.0]))])
    centre = cloud[:, :3].mean(dim=0).reshape(1, 1, 3)
    with torch.no_grad():
        outputs = network.forward_in_frames(cloud, frames, centre)
    assert outputs["directions"].shape == (2, len(network.measures), 3)
    np.testing.assert_allclose(outputs["directions"].norm(dim=-1), 1.0, atol=1e-5)
    # in the canonical frame, it is forward's answer
    frame, mean = canonical_frame(cloud[None, :, :3])
    with torch.no_grad():
        canonical = network.forward_in_frames(cloud, frame, mean)["directions"]
    np.testing.assert_allclose(canonical, answers(network, cloud[None]), atol=1e-5)


# network inputs


def test_network_inputs_put_the_features_of_the_chosen_rows_after_them():
    points = sample_surface(load_mesh(sample_path("mug.obj")), 3000, seed=2).points
    features = np.column_stack([np.arange(3000.0), -np.arange(3000.0)])  # names its row
    sizes: dict[str, Any] = {"n_points": 256, "n_fps": 64, "seed": 4, "name": "mug"}
    inputs = network_inputs(points, n_inputs=3, features=features, **sizes)
    assert inputs.shape == (3, 256, 5) and inputs.dtype == np.float32
    rows = network_indices(points, n_inputs=3, **{k: v for k, v in sizes.items() if k != "name"})
    assert rows.shape == (3, 256)
    np.testing.assert_array_equal(inputs[0, :, :3], network_points(points, **sizes))
    np.testing.assert_array_equal(inputs[..., 3:], features[rows])
    np.testing.assert_array_equal(network_inputs(points, n_inputs=3, **sizes), inputs[..., :3])


@pytest.mark.parametrize("features", [np.zeros((2999, 1)), np.zeros(3000)])
def test_network_inputs_refuse_features_of_other_rows(features):
    points = np.zeros((3000, 3))
    with pytest.raises(InputError, match=r"^mug: features: expected \(3000, F\) for 3000 points"):
        network_inputs(points, n_points=256, n_fps=64, seed=0, name="mug", features=features)


# the torch dataset


def test_torch_items_carry_the_stored_points_features_unturned(dataset_dir):
    with open_dataset(dataset_dir) as dataset:
        sizes: dict[str, Any] = {"n_points": 256, "n_fps": 64, "seed": 3,
                                 "point_features": ["face_area"]}
        turned = ViewpointTorchDataset(dataset, **sizes)
        still = ViewpointTorchDataset(dataset, rotate=False, **sizes)
        assert turned.point_features == FACE_AREA
        assert ViewpointTorchDataset(dataset, n_points=256, n_fps=64)[0]["points"].shape == (
            256, 3)
        for i in range(len(dataset)):
            stored = dataset[i]["points"]
            features = dataset.point_features(i, ["face_area"])
            assert features.shape == (len(stored), 1) and features.std() > 0.1
            item, plain = turned[i], still[i]
            assert item["points"].shape == (256, 4) and item["points"].dtype == torch.float32
            row_of = {point.tobytes(): row for row, point in enumerate(stored)}
            rows = [row_of[point.tobytes()] for point in plain["points"][:, :3].numpy()]
            np.testing.assert_array_equal(plain["points"][:, 3].numpy(), features[rows, 0])
            # a rotation turns the coordinates, never the features
            np.testing.assert_array_equal(item["points"][:, 3], plain["points"][:, 3])
            assert not np.allclose(item["points"][:, :3], plain["points"][:, :3], atol=1e-3)
            np.testing.assert_allclose(item["points"][:, :3],
                                       plain["points"][:, :3] @ item["rotation"].T, atol=1e-5)


def test_the_dataset_refuses_unknown_features(dataset_dir):
    with open_dataset(dataset_dir) as dataset:
        with pytest.raises(InputError, match=r"^point_features: unknown \['curvature'\]"):
            ViewpointTorchDataset(dataset, point_features=["curvature"])


def test_a_predictor_of_stored_points_takes_their_features_from_the_dataset(checkpoint,
                                                                          dataset_dir):
    with pytest.raises(InputError, match="reads point features \\(face_area\\); pass the dataset "
                                         "the points come from"):
        network_predictor(checkpoint)
    with open_dataset(dataset_dir) as dataset:
        predictor = network_predictor(checkpoint, dataset=dataset, n_inputs=2, device="cpu")
        found = predictor([dataset[i]["points"] for i in range(len(dataset))], dataset.names)
    assert found.shape == (2, 4, 3)
    np.testing.assert_allclose(np.linalg.norm(found, axis=-1), 1.0)
    answered = predict(checkpoint, dataset_dir, split=None, n_inputs=2, device="cpu")
    assert list(answered.names) == dataset.names
    np.testing.assert_allclose(answered.directions, found, atol=1e-5)


# meshes


def test_mesh_inputs_end_with_the_area_of_the_sampled_faces(checkpoint):
    mesh = load_mesh(sample_path("teapot.stl"))
    predictor = MeshPredictor(checkpoint, n_inputs=2)
    inputs = predictor.inputs(mesh)
    assert inputs.shape == (2, INPUT["n_points"], 4) and inputs.dtype == np.float32
    sample = sample_surface(mesh, N_SURFACE_POINTS, seed=0)
    feature = face_area_feature(mesh, sample.face_index)
    rows = network_indices(sample.points, seed=0, n_inputs=2, **INPUT)
    np.testing.assert_array_equal(inputs[0, :, :3],
                                  network_points(sample.points, seed=0, name="teapot", **INPUT))
    np.testing.assert_array_equal(inputs[..., 3], feature[rows])


def test_predict_on_a_mesh_file_is_the_mesh_predictors_answer(checkpoint):
    path = sample_path("teapot.stl")
    answered = predict(checkpoint, path, n_inputs=2, device="cpu")
    assert answered.names == ("teapot",)
    expected = MeshPredictor(checkpoint, n_inputs=2)(load_mesh(path))
    np.testing.assert_allclose(answered.directions[0], expected, atol=1e-5)


def test_a_point_file_cannot_feed_a_network_that_reads_point_features(checkpoint, tmp_path):
    path = tmp_path / "teapot.npy"
    np.save(path, sample_surface(load_mesh(sample_path("teapot.stl")), 2000).points)
    with pytest.raises(InputError, match="the network reads point features \\(face_area\\) that "
                                         "a point cloud does not carry"):
        predict(checkpoint, path, device="cpu")


def test_the_prior_proposes_unit_candidates_from_a_face_area_network(checkpoint):
    mesh = load_mesh(sample_path("mug.obj"))
    candidates = NetworkPrior(checkpoint)(mesh)
    assert candidates.ndim == 2 and candidates.shape[1] == 3 and len(candidates) >= 1
    np.testing.assert_allclose(np.linalg.norm(candidates, axis=1), 1.0)
    answer = MeshPredictor(checkpoint, n_inputs=1)(mesh)  # the prior asks the network once
    nearest = np.degrees(np.arccos(np.clip(answer @ candidates.T, -1, 1))).min(axis=1)
    assert nearest.max() <= 5.0 + 1e-9  # each answer, or one within min_angle_deg of it
