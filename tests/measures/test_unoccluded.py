"""The occlusion-free estimate: exact where nothing hides, any order of its four measures."""

import numpy as np
import pytest
import trimesh

from vptoolkit.best_view.prior import UnoccludedPrior
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.unoccluded import (
    UNOCCLUDED_MEASURES,
    mesh_elements,
    unoccluded_best_views,
    unoccluded_measures,
    unoccluded_quality,
)
from vptoolkit.mesh import Mesh
from vptoolkit.points import sample_surface
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere


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


def test_bad_pooling_and_a_flat_mesh_are_one_line_errors():
    with pytest.raises(InputError, match="cells"):
        unoccluded_quality(np.eye(3), np.ones(3), fibonacci_sphere(4), cells=0)
    line = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]]),
                name="line")
    with pytest.raises(InputError, match="line: the mesh has zero surface area"):
        mesh_elements(line)


def test_any_registered_measure_is_answered_or_refused_in_one_line(teapot):
    normals, areas = mesh_elements(teapot)
    every = unoccluded_best_views(normals, areas)
    chosen = unoccluded_best_views(normals, areas, measures="VMI,VE")
    np.testing.assert_array_equal(chosen, every[[3, 0]])
    assert unoccluded_measures("paper") == UNOCCLUDED_MEASURES
    with pytest.raises(InputError) as refused:
        unoccluded_best_views(normals, areas, measures="VE,SL,MD")
    assert str(refused.value) == ("measures: the unoccluded estimate has no closed form for SL, "
                                  "MD (it needs the drawn image); it estimates VE, VR, VKL, VMI")
    with pytest.raises(InputError, match="unknown measure 'XYZ'"):
        unoccluded_measures("XYZ")
