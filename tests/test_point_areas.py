import numpy as np
import pytest

from vptoolkit.errors import InputError
from vptoolkit.geometry import face_areas
from vptoolkit.io import load_mesh
from vptoolkit.point_areas import point_areas, point_radii
from vptoolkit.points import sample_surface
from vptoolkit.samples import sample_path


@pytest.mark.parametrize("name", ["bunny.ply", "torus.STL", "teapot.stl", "mug.obj"])
def test_areas_of_a_uniform_sample_sum_to_the_surface_area(name):
    mesh = load_mesh(sample_path(name))
    sample = sample_surface(mesh, 20000, seed=0)
    total = point_areas(sample.points).sum()
    assert total == pytest.approx(face_areas(mesh).sum(), rel=0.02)


def test_areas_follow_the_surface_not_the_sampling_density():
    # The left half of a unit square sampled four times as densely as the right:
    # each half still adds up to half of the area.
    rng = np.random.default_rng(1)
    left = rng.random((16000, 2)) * [0.5, 1.0]
    right = rng.random((4000, 2)) * [0.5, 1.0] + [0.5, 0.0]
    points = np.column_stack([np.concatenate([left, right]), np.zeros(20000)])
    areas = point_areas(points)
    inner_left = (points[:, 0] > 0.05) & (points[:, 0] < 0.45)
    inner_right = (points[:, 0] > 0.55) & (points[:, 0] < 0.95)
    assert areas[inner_left].mean() == pytest.approx(0.5 / 16000, rel=0.03)
    assert areas[inner_right].mean() == pytest.approx(0.5 / 4000, rel=0.03)
    assert areas.sum() == pytest.approx(1.0, rel=0.03)


def test_radius_is_the_kth_neighbour_distance_over_root_k():
    # points on a line 1 apart: the 4th neighbour of an inner point is 2 away
    points = np.column_stack([np.arange(20.0), np.zeros(20), np.zeros(20)])
    assert point_radii(points, k=4)[10] == pytest.approx(2.0 / 2.0)
    assert point_areas(points, k=4)[10] == pytest.approx(np.pi)


def test_every_radius_is_its_own_points_kth_neighbour_distance_on_a_scan():
    # an uneven, partial cloud, checked point by point against all pairwise distances:
    # the queries' order and threads change nothing
    from vptoolkit.scan import virtual_scan

    points, _ = virtual_scan(load_mesh(sample_path("teapot.stl")), 3, resolution=48, seed=2)
    pairwise = np.linalg.norm(points[:, None] - points[None], axis=2)
    kth = np.sort(pairwise, axis=1)[:, 8]  # the point itself first, at 0
    assert 500 < len(points) < 3000
    np.testing.assert_allclose(point_radii(points, k=8), kth / np.sqrt(8), rtol=1e-12)


@pytest.mark.parametrize(("points", "message"), [
    (np.zeros((10, 2)), r"points: expected an \(n, 3\) array"),
    (np.zeros((8, 3)), "need more than k = 8"),
    (np.full((20, 3), np.nan), "points: coordinates must be finite"),
])
def test_bad_points_give_one_line(points, message):
    with pytest.raises(InputError, match=message):
        point_areas(points)
