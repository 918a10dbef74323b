"""The occlusion-free estimate: exact where nothing hides, turns with the mesh, a search prior."""

import json

import numpy as np
import pytest
import trimesh
from click.testing import CliRunner

from vptoolkit.best_view import SearchSettings, coarse_directions, search_best_views
from vptoolkit.cli import main
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.mesh import Mesh
from vptoolkit.points import sample_surface
from vptoolkit.predictions import read_predictions
from vptoolkit.rotations import fixed_rotations
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.unoccluded import (
    UnoccludedPrior,
    mesh_elements,
    unoccluded_best_views,
    unoccluded_quality,
)


@pytest.fixture(scope="module")
def teapot() -> Mesh:
    return load_mesh(sample_path("teapot.stl"))


@pytest.mark.parametrize("shape, columns", [
    ("ellipsoid", (1, 2)),  # VR, VKL (its VE hardly changes with the direction)
    ("box", (0, 2)),  # VE, VKL: one, two or three sides in view
])
def test_on_a_convex_mesh_it_agrees_with_the_drawn_measures(shape, columns):
    if shape == "box":
        made = trimesh.creation.box(extents=(1.0, 2.0, 4.0)).subdivide()
        mesh = Mesh(made.vertices, made.faces, name=shape)
    else:
        made = trimesh.creation.icosphere(subdivisions=2)
        mesh = Mesh(made.vertices * [1.0, 2.0, 3.0], made.faces, name=shape)
    directions = fibonacci_sphere(64)
    estimate = unoccluded_quality(*mesh_elements(mesh), directions)
    drawn = compute_view_quality(mesh, MeasureSettings(resolution=256),
                                 view_directions=directions).raw
    for column in columns:  # nothing is hidden: only perspective and pixels differ
        assert np.corrcoef(estimate[:, column], drawn[:, column])[0, 1] > 0.9


def test_pooling_normals_keeps_the_estimate(teapot):
    directions = fibonacci_sphere(200)
    elements = mesh_elements(teapot)
    pooled = unoccluded_quality(*elements, directions)
    exact = unoccluded_quality(*elements, directions, cells=None)
    for column in range(3):
        assert np.corrcoef(pooled[:, column], exact[:, column])[0, 1] > 0.99
    np.testing.assert_allclose(pooled[:, 1], exact[:, 1], rtol=0.02)  # the projected share


def test_normals_are_made_unit_length(teapot):
    normals, areas = mesh_elements(teapot)
    directions = fibonacci_sphere(20)
    np.testing.assert_allclose(unoccluded_quality(3.0 * normals, areas, directions),
                               unoccluded_quality(normals, areas, directions), rtol=1e-9)


@pytest.mark.parametrize("length", [1e-300, 1e155, 1e300, np.finfo(np.float64).max])
def test_normals_of_any_finite_length_are_made_unit_length(teapot, length):
    # |n| of 1e155 overflows in float64 and used to give NaN and a ZeroDivisionError
    normals, areas = mesh_elements(teapot)
    directions = fibonacci_sphere(20)
    scaled = normals / np.abs(normals).max(axis=1, keepdims=True) * length  # no warning here
    np.testing.assert_allclose(unoccluded_quality(scaled, areas, directions),
                               unoccluded_quality(normals, areas, directions), rtol=1e-9)


def test_vmi_equals_vkl_and_a_uniform_sample_weighs_points_alike(teapot):
    normals, areas = mesh_elements(teapot)
    raw = unoccluded_quality(normals, areas, fibonacci_sphere(40))
    np.testing.assert_array_equal(raw[:, 3], raw[:, 2])
    sample = sample_surface(teapot, 5000, seed=0)
    np.testing.assert_array_equal(unoccluded_best_views(sample.normals),
                                  unoccluded_best_views(sample.normals, np.ones(5000)))


def test_points_with_normals_estimate_what_the_faces_do(teapot):
    directions = fibonacci_sphere(64)
    from_faces = unoccluded_quality(*mesh_elements(teapot), directions)
    sample = sample_surface(teapot, 20000, seed=0)
    from_points = unoccluded_quality(sample.normals, np.ones(20000), directions)
    for column in (1, 2):  # VR, VKL: area shares, which a uniform sample keeps
        assert np.corrcoef(from_faces[:, column], from_points[:, column])[0, 1] > 0.95


def test_a_mesh_wound_inside_out_gets_the_same_answer(teapot):
    inverted = Mesh(teapot.vertices, teapot.faces[:, ::-1], name="teapot")
    np.testing.assert_allclose(mesh_elements(inverted)[0], mesh_elements(teapot)[0])
    np.testing.assert_allclose(UnoccludedPrior()(inverted), UnoccludedPrior()(teapot), atol=1e-12)


def test_the_prior_turns_with_the_mesh(teapot):
    """The sphere turns with the mesh up to its axes' signs: the candidates stay as good."""
    prior = UnoccludedPrior()
    elements = mesh_elements(teapot)
    upright = unoccluded_quality(*elements, prior(teapot))
    for turn in fixed_rotations("teapot", 3):
        turned = prior(Mesh(teapot.vertices @ turn.T, teapot.faces, name="teapot")) @ turn
        again = unoccluded_quality(*elements, turned)
        assert np.nanmax(again[:, 0]) > 0.99 * np.nanmax(upright[:, 0])  # VE
        assert np.nanmin(again[:, 2]) < 1.05 * np.nanmin(upright[:, 2])  # VKL


def test_as_a_search_prior_its_first_candidate_is_drawn_at_full_resolution(teapot):
    candidates = UnoccludedPrior()(teapot)
    found = search_best_views(teapot, SearchSettings(budget=16, resolution=64), prior=candidates)
    assert [(s.name, s.n_views) for s in found.stages][:2] == [("coarse", 7), ("prior", 2)]
    again = search_best_views(teapot, SearchSettings(budget=16, resolution=64),
                              prior=UnoccludedPrior()(teapot))
    np.testing.assert_array_equal(found.directions, again.directions)


@pytest.mark.parametrize("normals, areas, message", [
    (np.zeros((4, 2)), np.ones(4), "expected shapes"),
    (np.eye(3), np.ones(2), "expected shapes"),
    (np.full((3, 3), np.nan), np.ones(3), "normals: a normal is NaN or infinite"),
    (np.full((3, 3), np.inf), np.ones(3), "normals: a normal is NaN or infinite"),
    (np.eye(3), -np.ones(3), "areas: expected finite values >= 0"),
    (np.eye(3), np.zeros(3), "zero area"),
    (np.zeros((3, 3)), np.ones(3), "normals: 3 of 3 normals have zero length"),
])
def test_bad_elements_are_one_line_errors(normals, areas, message):
    with pytest.raises(InputError, match=message):
        unoccluded_quality(normals, areas, fibonacci_sphere(8))


def test_bad_prior_options_and_a_flat_mesh_are_one_line_errors():
    with pytest.raises(InputError, match="n_directions"):
        UnoccludedPrior(0)
    with pytest.raises(InputError, match="cells"):
        unoccluded_quality(np.eye(3), np.ones(3), fibonacci_sphere(4), cells=0)
    with pytest.raises(InputError, match="min_angle_deg"):
        UnoccludedPrior(min_angle_deg=180.0)
    line = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]]),
                name="line")
    with pytest.raises(InputError, match="line: the mesh has zero surface area"):
        mesh_elements(line)


def test_command_with_the_unoccluded_prior(tmp_path):
    out = tmp_path / "best.npz"
    result = CliRunner().invoke(main, ["best-view", str(sample_path("teapot.stl")), "--views",
                                       "8", "--resolution", "48", "--prior", "unoccluded",
                                       "--json", "-o", str(out)])
    assert result.exit_code == 0, result.output
    entry = json.loads(result.stdout)["results"][0]
    assert [stage["stage"] for stage in entry["stages"]] == ["coarse", "prior"]
    assert entry["views"] == 8 and out.exists()


def test_the_sphere_of_the_prior_is_the_search_sphere(teapot):
    prior = UnoccludedPrior(n_directions=64, per_measure=1)
    assert all(np.isclose(np.abs(coarse_directions(teapot, 64) @ c).max(), 1.0)
               for c in prior(teapot))


def test_predict_unoccluded_of_a_mesh_a_scan_and_a_dataset(tmp_path, tiny_dataset, teapot):
    sample = sample_surface(teapot, 3000, seed=0)
    scan = tmp_path / "scan.npy"
    np.save(scan, np.hstack([sample.points, sample.normals]))
    out = tmp_path / "best.npz"
    result = CliRunner().invoke(main, ["predict", "--model", "unoccluded",
                                       str(sample_path("teapot.stl")), str(scan), "--dataset",
                                       str(tiny_dataset), "--split", "all", "-o", str(out)])
    assert result.exit_code == 0, result.output
    names, directions, measures = read_predictions(out)
    assert list(names[:2]) == ["teapot", "scan"] and len(names) == 6
    assert directions.shape == (6, 4, 3) and list(measures) == list(PAPER_MEASURES)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=2), 1.0)
    np.testing.assert_array_equal(directions[1], unoccluded_best_views(sample.normals))
    only_dataset = tmp_path / "dataset.npz"
    assert CliRunner().invoke(main, ["predict", "-m", "unoccluded", "--dataset",
                                     str(tiny_dataset), "--split", "all",
                                     "-o", str(only_dataset)]).exit_code == 0
    scored = CliRunner().invoke(main, ["evaluate", str(only_dataset), "--dataset",
                                       str(tiny_dataset), "--split", "all"])
    assert scored.exit_code == 0, scored.output


def test_predict_unoccluded_of_points_without_normals_exits_2(tmp_path, teapot):
    scan = tmp_path / "bare.npy"
    np.save(scan, sample_surface(teapot, 500, seed=0).points)
    result = CliRunner().invoke(main, ["predict", "--model", "unoccluded", str(scan)])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and "bare.npy: has no normals" in result.stderr
    assert "Traceback" not in result.output


def test_predict_unoccluded_of_normals_longer_than_1e154_is_the_unit_answer(tmp_path, teapot):
    sample = sample_surface(teapot, 2000, seed=0)
    unit, huge = tmp_path / "unit.npy", tmp_path / "huge.npy"
    np.save(unit, np.hstack([sample.points, sample.normals]))
    np.save(huge, np.hstack([sample.points, sample.normals * 1e155]))
    outputs = [CliRunner().invoke(main, ["predict", "-m", "unoccluded", str(path)])
               for path in (unit, huge)]
    assert [outcome.exit_code for outcome in outputs] == [0, 0], outputs[1].output
    assert outputs[1].stderr == ""
    assert outputs[1].stdout.replace("huge:", "unit:") == outputs[0].stdout


@pytest.mark.parametrize("stored, message", [
    (0.0, "model 'airplane_0001': 200 of 200 normals have zero length"),
    (np.nan, "model 'airplane_0001': a normal is NaN or infinite"),
])
def test_predict_unoccluded_of_broken_stored_normals_names_the_dataset_and_model(
        tmp_path, stored, message):
    import h5py

    from fixtures.stores import N_POINTS, write_synthetic

    store = write_synthetic(tmp_path / "dataset.h5")
    with h5py.File(store, "r+") as handle:  # damaged after writing, as on a bad disk
        handle["normals"][0] = np.full((N_POINTS, 3), stored)
    result = CliRunner().invoke(main, ["predict", "-m", "unoccluded", "--dataset", str(store),
                                       "--split", "all"])
    assert result.exit_code == 2, result.output
    assert result.stderr == f"vptool: error: {store}: {message}\n"
