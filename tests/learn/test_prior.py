"""The network as the best-view search's prior: its candidates and the frames it tries."""

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fixtures.environment import require_package
from fixtures.meshes import box_mesh
from vptoolkit.best_view.search import SearchSettings, search_best_views
from vptoolkit.errors import InputError
from vptoolkit.io import load, load_mesh
from vptoolkit.point_cloud import PointCloud
from vptoolkit.points import sample_surface
from vptoolkit.samples import sample_path

require_package("torch")

import torch  # noqa: E402

from vptoolkit.cli import main  # noqa: E402
from vptoolkit.learn.checkpoint import PRETRAINED  # noqa: E402
from vptoolkit.learn.frame import canonical_frame  # noqa: E402
from vptoolkit.learn.octahedral import sphere_map_directions  # noqa: E402
from vptoolkit.learn.predict import MeshPredictor  # noqa: E402
from vptoolkit.learn.prior import NetworkPrior, map_modes  # noqa: E402
from vptoolkit.sphere import distinct_directions  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def prior() -> NetworkPrior:
    return NetworkPrior("default")


def test_candidates_hold_the_networks_own_answer(prior):
    mesh = load_mesh(sample_path("mug.obj"))
    candidates = prior(mesh)
    np.testing.assert_allclose(np.linalg.norm(candidates, axis=1), 1.0)
    answer = MeshPredictor("default", n_inputs=1)(mesh)  # the prior asks the network once
    nearest = np.degrees(np.arccos(np.clip(answer @ candidates.T, -1, 1))).min(axis=1)
    assert nearest.max() <= 5.0 + 1e-9  # each answer, or one within min_angle_deg of it


def test_a_symmetric_box_is_tried_in_every_frame_of_its_ambiguous_signs(prior):
    box = box_mesh((1.0, 2.0, 4.0))
    points = torch.as_tensor(prior.predictor.inputs(box)[0])[:, :3]  # coordinates, not features
    frames, centre = prior.frames(points)
    assert len(frames) == 8  # three axes with a third moment of about 0
    canonical, _ = canonical_frame(points[None])
    torch.testing.assert_close(frames[0], canonical[0])
    for frame in frames:
        torch.testing.assert_close(frame @ frame.T, torch.eye(3), atol=1e-5, rtol=0)
    assert len(prior(box)) > 4


def test_forward_in_the_canonical_frame_is_forward(prior):
    model = prior.predictor.model.eval()
    points = torch.as_tensor(prior.predictor.inputs(load_mesh(sample_path("teapot.stl")))[0])
    frame, centre = canonical_frame(points[None, :, :3])
    with torch.inference_mode():
        torch.testing.assert_close(model.forward_in_frames(points, frame, centre)["directions"],
                                   model(points[None])["directions"])


def test_distinct_directions_keeps_the_first_of_close_ones():
    directions = np.array([[0, 0, 1.0], [0, np.sin(0.01), np.cos(0.01)], [1.0, 0, 0]])
    np.testing.assert_array_equal(distinct_directions(directions, 5.0), directions[[0, 2]])


def test_best_view_with_the_default_prior_draws_its_candidates_first():
    result = CliRunner().invoke(main, ["best-view", str(sample_path("mug.obj")), "--views", "16",
                                       "--resolution", "48", "--prior", "default", "--json"])
    assert result.exit_code == 0, result.output
    stages = json.loads(result.stdout)["results"][0]["stages"]
    assert [stage["stage"] for stage in stages][:2] == ["coarse", "prior (network default)"]
    assert sum(stage["views"] for stage in stages) == 16


@pytest.fixture(scope="module")
def bunny_cloud(tmp_path_factory) -> Path:
    """3000 points sampled on the bundled bunny, written by Open3D as a bare cloud (no
    normals)."""
    o3d = pytest.importorskip("open3d")
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(
        sample_surface(load_mesh(sample_path("bunny.ply")), 3000, seed=0).points))
    path = tmp_path_factory.mktemp("cloud") / "bunny_cloud.ply"
    o3d.io.write_point_cloud(str(path), cloud)
    return path


def test_the_default_prior_answers_a_bare_cloud_with_the_network_of_coordinates(
        prior, bunny_cloud):
    cloud = load(bunny_cloud)
    assert isinstance(cloud, PointCloud) and cloud.normals is None
    candidates = prior(cloud)
    assert prior.label(cloud) == "network points"
    assert prior.label(load_mesh(sample_path("bunny.ply"))) == "network default"
    np.testing.assert_allclose(np.linalg.norm(candidates, axis=1), 1.0)
    np.testing.assert_array_equal(candidates, NetworkPrior("points")(cloud))
    found = search_best_views(cloud, SearchSettings(budget=8, resolution=32), prior=candidates)
    assert [stage.name for stage in found.stages] == ["coarse", "prior"]


def test_best_view_of_a_cloud_with_the_default_prior_names_the_network(bunny_cloud):
    result = CliRunner().invoke(main, ["best-view", str(bunny_cloud), "--views", "8",
                                       "--resolution", "32", "--prior", "default"])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("bunny_cloud: 8 views (7 coarse @ 32, "
                                    "1 prior (network points) @ 32), ")


def test_a_checkpoint_of_face_areas_refuses_a_bare_cloud_in_one_line(bunny_cloud):
    face_areas = NetworkPrior(PRETRAINED)  # the default network's files, not its name
    with pytest.raises(InputError, match=r"^bunny_cloud: the network reads point features "
                                         r"\(face_area\) that a point cloud does not carry; "):
        face_areas(load(bunny_cloud))


def test_map_modes_are_the_highest_cells_far_enough_apart():
    cells = sphere_map_directions(16, dtype=torch.float64).reshape(-1, 3)
    up, side = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64), torch.tensor([1.0, 0, 0],
                                                                                 dtype=torch.float64)
    values = 2.0 * torch.exp(-8 * (1 - cells @ up)) + torch.exp(-8 * (1 - cells @ side))
    maps = values.reshape(1, 1, 16, 16)
    turn = torch.tensor([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]], dtype=torch.float64)[None]
    first, second, third = map_modes(maps, turn, 3, 30.0)
    assert np.degrees(np.arccos(first[0, 0] @ (up @ turn[0]).numpy())) < 10
    assert np.degrees(np.arccos(second[0, 0] @ (side @ turn[0]).numpy())) < 10
    for other in (first, second):
        assert float(third[0, 0] @ other[0, 0]) < np.cos(np.radians(30.0))


def _best_view_with_prior(prior) -> tuple[int, list[str]]:
    """Exit code and error lines of best-view on the mug with ``--prior prior``."""
    result = CliRunner().invoke(main, ["best-view", str(sample_path("mug.obj")), "--views", "8",
                                       "--resolution", "32", "--prior", str(prior)])
    assert "Traceback" not in result.output and "Warning" not in result.output
    lines = result.stderr.replace("\r", "\n").splitlines()
    return result.exit_code, [line for line in lines if line.startswith("vptool:")]


@pytest.mark.parametrize("command", ["best-view", "predict"])
def test_a_missing_checkpoint_file_is_said_not_to_exist(tmp_path, command):
    missing = tmp_path / "missing.safetensors"
    if command == "best-view":
        code, errors = _best_view_with_prior(missing)
    else:
        result = CliRunner().invoke(main, ["predict", "-m", str(missing),
                                           str(sample_path("mug.obj"))])
        code, errors = result.exit_code, result.stderr.splitlines()
    assert code == 2
    assert errors == [f"vptool: error: {missing}: no such checkpoint (a folder, *.safetensors "
                      "or *.json file, or a bundled name: 'default', 'points')"]


def test_a_per_category_folder_as_prior_says_best_view_takes_one_network(tmp_path):
    folder = tmp_path / "per"
    folder.mkdir()
    (folder / "categories.json").write_text('{"format": "x", "categories": {}}')
    code, errors = _best_view_with_prior(folder)
    assert code == 2 and len(errors) == 1
    assert errors[0].startswith(f"vptool: error: {folder}: holds one network per category")
    assert "best-view has no --category" in errors[0]


def test_a_prior_with_all_zero_weights_is_one_line_saying_they_are_broken(tmp_path):
    from fixtures.networks import TINY_CONFIG
    from vptoolkit.learn import model as M

    network = M.ViewpointNet(TINY_CONFIG)
    with torch.no_grad():
        for parameter in network.parameters():
            parameter.zero_()
    M.save_model(network, tmp_path / "zero")
    code, errors = _best_view_with_prior(tmp_path / "zero")
    assert code == 2 and len(errors) == 1
    assert errors[0].startswith(f"vptool: error: {tmp_path / 'zero'}: the network answers a zero")
    assert errors[0].endswith("its weights are broken")
