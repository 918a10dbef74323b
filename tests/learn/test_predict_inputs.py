"""Several network inputs per model: the bundled network's answers and their consensus."""

import numpy as np
import pytest

from fixtures.environment import require_package
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.points import N_SURFACE_POINTS, sample_surface
from vptoolkit.samples import sample_path

require_package("torch")

from vptoolkit.learn.consensus import consensus_directions  # noqa: E402
from vptoolkit.learn.draws import (  # noqa: E402
    N_INPUTS,
    content_order,
    network_indices,
    network_inputs,
    network_points,
)
from vptoolkit.learn.predict import (  # noqa: E402
    MeshPredictor,
    mesh_surface,
    network_predictor,
    predict,
    predict_directions,
)

pytestmark = pytest.mark.usefixtures("one_thread")

MESHES = ("mug.obj", "teapot.stl")


@pytest.fixture(scope="module")
def predictor() -> MeshPredictor:
    return MeshPredictor("default")


def surface(name: str) -> np.ndarray:
    """The surface points that predict and MeshPredictor sample from a mesh (seed 0)."""
    return sample_surface(load_mesh(sample_path(name)), N_SURFACE_POINTS, seed=0).points


def face_areas(name: str) -> np.ndarray:
    """The bundled network's point features of :func:`surface`'s points."""
    return mesh_surface(load_mesh(sample_path(name)), ("face_area",), seed=0)[1]


def test_one_input_is_the_single_draw_zero_answer(predictor):
    single = MeshPredictor("default", n_inputs=1)
    for name in MESHES:
        mesh = load_mesh(sample_path(name))
        draw_zero = network_inputs(surface(name), n_points=predictor.n_points,
                                   n_fps=predictor.n_fps, seed=0, name=mesh.name, n_inputs=1,
                                   features=face_areas(name))
        expected = predict_directions(predictor.model, draw_zero)[0]
        assert np.allclose(single(mesh), expected, atol=1e-5)
        answered = predict("default", sample_path(name), n_inputs=1, device="cpu")
        assert np.allclose(answered.directions[0], expected, atol=1e-5)


def test_the_inputs_are_distinct_draws_the_first_being_the_single_input(predictor):
    points = surface("mug.obj")
    sizes = {"n_points": predictor.n_points, "n_fps": predictor.n_fps, "seed": 0, "name": "mug"}
    inputs = network_inputs(points, n_inputs=5, **sizes)
    assert inputs.shape == (5, predictor.n_points, 3) and inputs.dtype == np.float32
    np.testing.assert_array_equal(inputs[0], network_points(points, **sizes))
    np.testing.assert_array_equal(inputs[:3], network_inputs(points, n_inputs=3, **sizes))
    chosen = [{tuple(point) for point in draw} for draw in inputs]
    assert all(chosen[i] != chosen[j] for i in range(5) for j in range(i))
    # every input holds the model's one farthest-point subset first
    assert all(np.array_equal(draw[:predictor.n_fps], inputs[0, :predictor.n_fps])
               for draw in inputs)
    assert network_inputs(points, **sizes).shape[0] == N_INPUTS
    # the same draws from the same points and seed, whatever the name; another seed draws others
    np.testing.assert_array_equal(network_inputs(points, n_inputs=5, **sizes), inputs)
    np.testing.assert_array_equal(
        network_inputs(points, n_inputs=5, **{**sizes, "name": "zebra"}), inputs)
    assert not np.array_equal(network_inputs(points, n_inputs=5, **{**sizes, "seed": 1}), inputs)
    np.testing.assert_array_equal(predictor.inputs(load_mesh(sample_path("mug.obj"))),
                                  network_inputs(points, **sizes, features=face_areas("mug.obj")))


def test_the_inputs_follow_the_points_in_any_order():
    points = surface("teapot.stl")
    sizes = {"n_points": 512, "n_fps": 128, "seed": 0, "name": "teapot"}
    shuffled = np.random.default_rng(5).permutation(len(points))
    order, key = content_order(points)
    radii = np.linalg.norm(points[order] - points.mean(axis=0), axis=1)
    assert np.all(np.diff(radii) >= 0)
    turn = np.linalg.qr(np.random.default_rng(6).normal(size=(3, 3)))[0]
    assert content_order(points[shuffled])[1] == key
    moved_order, moved_key = content_order(points @ turn.T * 3.0 + 1.0)
    assert moved_key == key
    np.testing.assert_array_equal(moved_order, order)
    assert content_order(points[:-1])[1] != key  # other points, other key
    rows = network_indices(points, n_inputs=3, **{k: v for k, v in sizes.items() if k != "name"})
    again = network_indices(points[shuffled], n_inputs=3,
                            **{k: v for k, v in sizes.items() if k != "name"})
    np.testing.assert_array_equal(points[rows], points[shuffled][again])
    np.testing.assert_array_equal(network_inputs(points[shuffled], n_inputs=3, **sizes),
                                  network_inputs(points, n_inputs=3, **sizes))


def test_the_answer_depends_on_the_points_not_the_file(tmp_path):
    import open3d as o3d

    points = surface("mug.obj").astype(np.float32)
    np.save(tmp_path / "a.npy", points)
    np.save(tmp_path / "zebra.npy", points)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float64)))
    o3d.io.write_point_cloud(str(tmp_path / "mug.ply"), cloud)
    files = [tmp_path / "a.npy", tmp_path / "zebra.npy", tmp_path / "mug.ply"]
    answered = predict("points", files, device="cpu", n_inputs=4)
    assert answered.names == ("a", "zebra", "mug")
    np.testing.assert_array_equal(answered.directions[1], answered.directions[0])
    np.testing.assert_array_equal(answered.directions[2], answered.directions[0])
    from_clouds = network_predictor("points", device="cpu", n_inputs=4)
    # the same inputs in another batch: the same answers up to the rounding of batched sums
    np.testing.assert_allclose(from_clouds([points, points[::-1]], ["b", "c"]),
                               answered.directions[:2], atol=1e-5)


def test_a_batch_on_two_threads_answers_each_cloud_as_it_is_answered_alone():
    from vptoolkit.learn.model import torch_threads

    mug, teapot = surface("mug.obj"), surface("teapot.stl")
    network = network_predictor("points", device="cpu", n_inputs=4)
    alone = np.concatenate([network([mug], ["mug"]), network([teapot], ["teapot"])])
    with torch_threads(2):  # the input draws of the batch on two threads
        together = network([teapot, mug[::-1], mug], ["t", "reversed", "m"])
    # the same inputs, answered in another batch: equal up to the rounding of batched sums
    np.testing.assert_allclose(together[[2, 0]], alone, atol=1e-5)
    np.testing.assert_array_equal(together[1], together[2])  # order and name change nothing


def test_the_consensus_is_one_of_the_single_input_answers(predictor):
    for name in MESHES:
        mesh = load_mesh(sample_path(name))
        answers = predict_directions(predictor.model, predictor.inputs(mesh))
        assert answers.shape == (N_INPUTS, len(predictor.measures), 3)
        chosen = predictor(mesh)
        assert chosen.shape == (len(predictor.measures), 3)
        for measure in range(len(predictor.measures)):
            # the same vector up to the rounding of normalising a unit vector again
            gaps = np.abs(answers[:, measure] - chosen[measure]).max(axis=-1)
            assert gaps.min() < 1e-12, (name, predictor.measures[measure], gaps)
        np.testing.assert_array_equal(chosen, consensus_directions(answers[None])[0])


def test_predict_and_the_mesh_predictor_agree_and_repeat(predictor):
    paths = [sample_path(name) for name in MESHES]
    answered = predict("default", paths, device="cpu")
    assert answered.names == ("mug", "teapot") and answered.measures == predictor.measures
    for path, directions in zip(paths, answered.directions):
        assert np.allclose(directions, predictor(load_mesh(path)), atol=1e-5)
    again = predict("default", paths, device="cpu")
    assert again.directions.tobytes() == answered.directions.tobytes()
    # a network of coordinates alone answers bare clouds as predict answers their meshes
    from_clouds = network_predictor("points", device="cpu")
    clouds = [surface(name) for name in MESHES]
    assert np.allclose(from_clouds(clouds, ["mug", "teapot"]),
                       predict("points", paths, device="cpu").directions, atol=1e-5)


@pytest.mark.parametrize("n_inputs", [0, 65, 1.5, True, "8", None])
def test_a_bad_number_of_inputs_is_refused(n_inputs):
    mug = sample_path("mug.obj")
    calls = (lambda: predict("default", mug, n_inputs=n_inputs),
             lambda: MeshPredictor("default", n_inputs=n_inputs),
             lambda: network_predictor("default", n_inputs=n_inputs))
    for call in calls:
        with pytest.raises(InputError, match="^n_inputs: expected an integer from 1 to 64"):
            call()


def test_the_bundled_network_hands_a_bare_cloud_to_the_network_of_coordinates(tmp_path):
    cloud = tmp_path / "mug_points.npy"
    np.save(cloud, surface("mug.obj"))
    mixed = predict("default", [sample_path("teapot.stl"), cloud], device="cpu", n_inputs=2)
    assert mixed.names == ("teapot", "mug_points")
    alone = predict("points", cloud, device="cpu", n_inputs=2)
    np.testing.assert_array_equal(mixed.directions[1], alone.directions[0])
    mesh = predict("default", sample_path("teapot.stl"), device="cpu", n_inputs=2)
    np.testing.assert_array_equal(mixed.directions[0], mesh.directions[0])
