import numpy as np
import pytest

from fixtures.environment import require_package
from vptoolkit.camera import Camera
from vptoolkit.errors import InputError
from vptoolkit.geometry import bounding_frame
from vptoolkit.io import load_mesh
from vptoolkit.samples import sample_path
from vptoolkit.scan import scanner_directions, virtual_scan


@pytest.fixture(scope="module")
def bunny():
    return load_mesh(sample_path("bunny.ply"))


def _distances(mesh, points):
    require_package("open3d")
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(mesh.vertices.astype(np.float32), mesh.faces.astype(np.uint32))
    return scene.compute_distance(points.astype(np.float32)).numpy()


def test_the_same_seed_gives_the_same_cloud_and_another_seed_another(bunny):
    points, normals = virtual_scan(bunny, seed=3)
    again, again_normals = virtual_scan(bunny, seed=3)
    np.testing.assert_array_equal(points, again)
    np.testing.assert_array_equal(normals, again_normals)
    other, _ = virtual_scan(bunny, seed=4)
    assert other.shape != points.shape or not np.array_equal(other, points)


def test_points_without_noise_lie_on_the_surface(bunny):
    points, normals = virtual_scan(bunny, noise=0.0)
    diagonal = bounding_frame(bunny)[1]
    assert len(points) > 3000
    assert _distances(bunny, points).max() < 1e-5 * diagonal
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0)


def test_noise_moves_points_off_the_surface_by_about_its_size(bunny):
    points, _ = virtual_scan(bunny, noise=0.005)
    diagonal = bounding_frame(bunny)[1]
    distance = _distances(bunny, points) / diagonal
    # along the ray, so the distance to the surface is at most the range error
    assert 0.001 < np.sqrt(np.mean(distance**2)) <= 0.005
    assert np.quantile(distance, 0.99) < 4 * 0.005


def test_a_scan_sees_only_the_side_facing_its_scanner():
    # one scanner looking at a sphere: every point is on the near cap, with
    # its normal towards the scanner
    sphere = load_mesh(sample_path("ballA.off"))
    centre, diagonal = bounding_frame(sphere)
    points, normals = virtual_scan(sphere, n_scans=1, noise=0.0, seed=5)
    direction = scanner_directions(1, seed=5)[0]
    eye = centre + Camera().distance_factor * diagonal * direction
    assert ((points - centre) @ direction > 0.0).all()
    assert (np.einsum("ij,ij->i", normals, eye - points) > 0.0).all()


def test_more_scanners_see_more_of_the_model(bunny):
    one, _ = virtual_scan(bunny, n_scans=1, seed=0)
    three, _ = virtual_scan(bunny, n_scans=3, seed=0)
    assert len(three) > 2 * len(one)


@pytest.mark.parametrize(("arguments", "message"), [
    ({"n_scans": 0}, "n_scans"),
    ({"noise": -0.1}, r"noise: expected a number >= 0"),
    ({"resolution": 0}, "resolution"),
])
def test_bad_arguments_give_one_line(bunny, arguments, message):
    with pytest.raises(InputError, match=message):
        virtual_scan(bunny, **arguments)
