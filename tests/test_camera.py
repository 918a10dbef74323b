import math

import numpy as np
import pytest

from vptoolkit.camera import Camera
from vptoolkit.errors import InputError
from vptoolkit.sphere import fibonacci_sphere


def test_default_camera_matches_the_documented_conventions():
    record = Camera().to_dict()
    assert record["fov_deg"] == 45.0
    assert record["distance_factor"] == pytest.approx(1 / math.sin(math.radians(45)))
    assert record["up"] == [0.0, -1.0, 0.0]
    assert record["cull_back_faces"] is True


def test_poses_are_orthonormal_and_look_at_the_centre():
    views = fibonacci_sphere(200)
    centre = np.array([1.0, 2.0, 3.0])
    poses = Camera().poses(views, centre=centre, diagonal=2.0, resolution=64)
    for axis in (poses.right, poses.up, poses.forward):
        np.testing.assert_allclose(np.linalg.norm(axis, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("ij,ij->i", poses.right, poses.up), 0.0, atol=1e-12)
    np.testing.assert_allclose(poses.forward, -views, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(poses.eyes - centre, axis=1), 2.0 * math.sqrt(2.0))
    # the centre projects to the middle of the image in every view
    for view in (0, 57, 199):
        x, y, _ = poses.project(view, centre[None, :])[0]
        assert (x, y) == pytest.approx((32.0, 32.0))


def test_image_up_is_minus_y_and_rows_grow_downwards():
    poses = Camera().poses([[0, 0, 1]], centre=np.zeros(3), diagonal=1.0, resolution=100)
    np.testing.assert_allclose(poses.up[0], [0, -1, 0])
    # a point towards -y (image up) lands above the centre (smaller row)
    assert poses.project(0, [[0, -0.1, 0]])[0, 1] < 50.0


def test_fallback_up_where_the_view_is_parallel_to_up():
    poses = Camera().poses([[0, 1, 0], [0, -1, 0]], centre=np.zeros(3), diagonal=1.0, resolution=8)
    assert np.isfinite(poses.right).all()
    np.testing.assert_allclose(np.abs(poses.right @ [0, 0, 1]), 0.0, atol=1e-12)


def test_pixel_rays_pass_through_pixel_centres():
    poses = Camera().poses([[0.3, 0.5, 0.8]], centre=np.zeros(3), diagonal=1.0, resolution=16)
    rays = poses.pixel_rays(0).astype(np.float64)
    points = rays[:, :3] + 5.0 * rays[:, 3:]
    pixels = poses.project(0, points)
    expected_x, expected_y = np.meshgrid(np.arange(16) + 0.5, np.arange(16) + 0.5)
    np.testing.assert_allclose(pixels[:, 0], expected_x.ravel(), atol=1e-4)
    np.testing.assert_allclose(pixels[:, 1], expected_y.ravel(), atol=1e-4)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"fov_deg": 0}, "^fov_deg"), ({"distance_factor": 0.5}, "^distance_factor"),
     ({"up": (0, 0, 0)}, "^up"), ({"fallback_up": (0, -2, 0)}, "^fallback_up")],
    ids=["fov", "too-close", "zero-up", "parallel-fallback"],
)
def test_bad_camera_parameters_are_rejected(kwargs, message):
    with pytest.raises(InputError, match=message):
        Camera(**kwargs)
