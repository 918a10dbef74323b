"""Point normals, the vector point feature: they turn wherever the points turn (the canonical
frame, the frames of the prior, the torch dataset, the validation inputs, the protocol's
predictor), so a network that reads them answers a turned model with its answer turned."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.networks import TINY_CONFIG, calibrated
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.mesh import Mesh
from vptoolkit.point_features import point_features, turn_features
from vptoolkit.points import sample_surface
from vptoolkit.rotations import fixed_rotations, random_rotation
from vptoolkit.samples import sample_path

require_package("torch")
require_package("safetensors")
require_package("zarr")

import torch  # noqa: E402

from vptoolkit.data import open_dataset  # noqa: E402
from vptoolkit.data.torch import ViewpointTorchDataset  # noqa: E402
from vptoolkit.learn.frame import canonical_frame  # noqa: E402
from vptoolkit.learn.model import ViewpointNet, save_model  # noqa: E402
from vptoolkit.learn.predict import MeshPredictor, network_predictor, stored_turn  # noqa: E402
from vptoolkit.learn.validation import validation_inputs  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_thread")

NORMALS = ("face_area", "normal")
CONFIG = dataclasses.replace(TINY_CONFIG, point_features=NORMALS)
"""The tests' tiny network, reading each point's face area and face normal."""
INPUT = {"n_points": 512, "n_fps": 128}
TURN = random_rotation(np.random.default_rng(11))


def surface_cloud(mesh: Mesh, n: int, seed: int) -> np.ndarray:
    """(n, 7): points sampled on ``mesh``, their face area and their face normal."""
    sample = sample_surface(mesh, n, seed=seed)
    features = point_features(sample.points, NORMALS, mesh=mesh, face_index=sample.face_index)
    return np.column_stack([sample.points, features])


def turned(cloud: np.ndarray | torch.Tensor, rotation: np.ndarray) -> np.ndarray:
    """``cloud`` turned by ``rotation``: its coordinates and its normals, as the mesh would."""
    cloud = np.asarray(cloud, dtype=np.float64)
    return np.column_stack([cloud[:, :3] @ rotation.T,
                            turn_features(cloud[:, 3:], NORMALS, rotation.T)])


def angles(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(np.sum(first * second, axis=-1), -1.0, 1.0)))


@pytest.fixture(scope="module")
def network(one_thread: None) -> ViewpointNet:
    """The untrained network of face area and normals, calibrated on four sample meshes."""
    clouds = np.stack([surface_cloud(load_mesh(sample_path(name)), 2048, seed=1)
                       for name in ("teapot.stl", "mug.obj", "bunny.ply", "suzanne.ply")])
    return calibrated(ViewpointNet(CONFIG, seed=0), clouds)


@pytest.fixture(scope="module")
def cloud() -> np.ndarray:
    """(2048, 7) points of the teapot with their features."""
    return surface_cloud(load_mesh(sample_path("teapot.stl")), 2048, seed=0)


@pytest.fixture(scope="module")
def checkpoint(network: ViewpointNet, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("normals_net") / "net.safetensors"
    save_model(network, path, metadata={"input": INPUT})
    return path


def answers(model: ViewpointNet, clouds: np.ndarray) -> np.ndarray:
    with torch.no_grad():
        return model(torch.from_numpy(np.asarray(clouds, np.float32)))["directions"].numpy()


def test_the_configuration_counts_three_columns_for_the_normal():
    assert CONFIG.input_channels == 7


def test_a_turned_cloud_gets_its_answer_turned(network, cloud):
    first = answers(network, cloud[None])[0]
    assert angles(answers(network, turned(cloud, TURN)[None])[0], first @ TURN.T).max() < 0.05
    # normals left unturned are another input: the network reads them
    stale = np.column_stack([cloud[:, :3] @ TURN.T, cloud[:, 3:]])
    assert angles(answers(network, stale[None])[0], first @ TURN.T).max() > 1.0


def test_the_normals_change_the_answer(network, cloud):
    flipped = cloud.copy()
    flipped[:, 4:] *= -1.0  # the same mesh wound the other way
    assert angles(answers(network, flipped[None])[0], answers(network, cloud[None])[0]).max() > 1.0


def test_forward_in_frames_turns_the_normals_with_each_frame(network, cloud):
    points = torch.from_numpy(cloud.astype(np.float32))
    frame, centre = canonical_frame(points[None, :, :3])
    flips = torch.stack([torch.eye(3), torch.diag(torch.tensor([1.0, -1.0, -1.0]))])
    frames = flips @ frame  # the canonical frame and one with two axes flipped
    turn = torch.from_numpy(TURN.T.astype(np.float32))
    with torch.no_grad():
        seen = network.forward_in_frames(points, frames, centre)["directions"].numpy()
        # the turned cloud in the turned frames is the same input to the network
        again = network.forward_in_frames(torch.from_numpy(turned(cloud, TURN).astype(np.float32)),
                                          frames @ turn, centre @ turn)["directions"].numpy()
    assert angles(again, seen @ TURN.T).max() < 0.05
    np.testing.assert_allclose(seen[:1], answers(network, cloud[None]), atol=1e-5)


def test_the_mesh_predictor_turns_with_the_mesh(checkpoint):
    mesh = load_mesh(sample_path("teapot.stl"))
    predictor = MeshPredictor(checkpoint, n_inputs=2)
    first = predictor(mesh)
    moved = predictor(Mesh(mesh.vertices @ TURN.T, mesh.faces, name=mesh.name))
    assert np.median(angles(moved, first @ TURN.T)) < 1.0


def test_torch_items_turn_the_normals_with_the_points(features_dataset):
    with open_dataset(features_dataset) as dataset:
        sizes = {"n_points": 256, "n_fps": 64, "seed": 3, "point_features": NORMALS}
        moving = ViewpointTorchDataset(dataset, **sizes)
        still = ViewpointTorchDataset(dataset, rotate=False, **sizes)
        for i in range(len(dataset)):
            item, plain = moving[i], still[i]
            assert item["points"].shape == (256, 7)
            rotation = item["rotation"].numpy().astype(np.float64)
            np.testing.assert_allclose(item["points"].numpy(), turned(plain["points"], rotation),
                                       atol=1e-5)
            normals = plain["points"][:, 4:].numpy()
            np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)


def test_validation_inputs_turn_the_normals_with_the_points(features_dataset):
    with open_dataset(features_dataset) as dataset:
        sizes = {"n_points": 256, "n_fps": 64, "seed": 2, "device": torch.device("cpu"),
                 "point_features": NORMALS}
        still = validation_inputs(dataset, 2, rotations=0, **sizes)["points"].numpy()
        moving = validation_inputs(dataset, 2, rotations=3, **sizes)["points"].numpy()
        assert moving.shape == (6, 256, 7)
        for model, name in enumerate(dataset.names):
            for k, rotation in enumerate(fixed_rotations(name, 3, seed=2)):
                np.testing.assert_allclose(moving[3 * model + k], turned(still[model], rotation),
                                           atol=1e-5)


def test_the_protocols_predictor_turns_the_stored_normals_with_each_cloud(checkpoint,
                                                                          features_dataset):
    with open_dataset(features_dataset) as dataset:
        predictor = network_predictor(checkpoint, dataset=dataset, n_inputs=2, device="cpu")
        stored = [dataset[i]["points"] for i in range(len(dataset))]
        first = predictor(stored, dataset.names)
        moved = predictor([points @ TURN.T for points in stored], dataset.names)
        assert np.median(angles(moved, first @ TURN.T)) < 1.0
        with pytest.raises(InputError, match="^mug: the points are not the dataset's stored "
                                             "points turned about the origin"):
            predictor([stored[0] + 0.01, stored[1]], dataset.names)


def test_stored_turn_finds_a_rotation_and_refuses_other_shapes(cloud):
    points = cloud[:, :3]
    np.testing.assert_allclose(stored_turn(points, (points @ TURN.T).astype(np.float32), "m"),
                               TURN.T, atol=1e-5)
    with pytest.raises(InputError, match=r"^m: expected the dataset's 2048 stored points"):
        stored_turn(points, points[:10], "m")


def test_features_in_another_order_than_trained_are_refused(checkpoint, tmp_path):
    import json
    import shutil

    from vptoolkit.learn.checkpoint import checkpoint_paths
    from vptoolkit.learn.model import load_model

    copy = tmp_path / "net.safetensors"
    shutil.copy(checkpoint, copy)
    config_path = checkpoint_paths(copy)[1]
    config = json.loads(checkpoint_paths(checkpoint)[1].read_text())
    trained = list(config["architecture"]["point_features"])
    config["training"] = {"arguments": {"architecture": {"point_features": trained}}}
    config_path.write_text(json.dumps(config))
    assert load_model(copy)[0].config.point_features == tuple(trained)  # as recorded: loads
    config["architecture"]["point_features"] = trained[::-1]  # same widths, channels swapped
    config_path.write_text(json.dumps(config))
    with pytest.raises(InputError, match=r"net.json: architecture.point_features "
                                         r"\['normal', 'face_area'\] are not the "
                                         r"\['face_area', 'normal'\] the network was trained"):
        load_model(copy)


def test_a_network_of_normals_reads_the_normals_of_an_n6_point_file(tmp_path):
    from vptoolkit.learn.predict import predict

    checkpoint = tmp_path / "normal.safetensors"
    save_model(ViewpointNet(dataclasses.replace(TINY_CONFIG, point_features=("normal",)),
                            seed=0), checkpoint, metadata={"input": INPUT})
    mesh = load_mesh(sample_path("teapot.stl"))
    sample = sample_surface(mesh, 2048, seed=0)
    normals = point_features(sample.points, ("normal",), mesh=mesh, face_index=sample.face_index)
    with_normals, bare = tmp_path / "with.npy", tmp_path / "bare.npy"
    np.save(with_normals, np.column_stack([sample.points, 3.0 * normals]))  # any length
    np.save(bare, sample.points)
    answer = predict(checkpoint, with_normals, n_inputs=1, device="cpu")
    assert answer.directions.shape == (1, len(TINY_CONFIG.measures), 3)
    np.save(with_normals, np.column_stack([sample.points, normals]))
    np.testing.assert_allclose(predict(checkpoint, with_normals, n_inputs=1,
                                       device="cpu").directions, answer.directions, atol=1e-6)
    with pytest.raises(InputError, match=r"bare.npy: the network reads point features \(normal\) "
                                         r"that a point cloud without normals does not carry"):
        predict(checkpoint, bare, n_inputs=1, device="cpu")
