import math

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.meshes import primitive_mesh
from vptoolkit.camera import Camera
from vptoolkit.conventions import DISTANCE_FACTOR
from vptoolkit.errors import InputError
from vptoolkit.geometry import bounding_frame, face_normals
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.visibility import face_id_images


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


# Poses for renderers: camera-to-world 4x4 in the OpenCV and OpenGL frames, intrinsics K.

AWKWARD_VIEWS = [[0.3, 0.5, 0.8], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [-0.7, 0.1, -0.2]]
"""An oblique view, both views along ``up`` (the fallback frame) and one from behind."""


def _project(pose_opencv, intrinsics, points):
    """Pixel coordinates ``(n, 2)`` and depths ``(n,)`` of model points, through ``inv(pose)``."""
    extrinsic = np.linalg.inv(pose_opencv)
    camera_points = points @ extrinsic[:3, :3].T + extrinsic[:3, 3]
    homogeneous = camera_points @ intrinsics.T
    return homogeneous[:, :2] / homogeneous[:, 2:], camera_points[:, 2]


@pytest.fixture(scope="module")
def mug_poses():
    from vptoolkit.io import load_mesh
    from vptoolkit.samples import sample_path

    mug = load_mesh(sample_path("mug.obj"))
    return mug, Camera().look_at(mug, AWKWARD_VIEWS, resolution=96)


def test_the_centre_projects_to_the_image_centre_and_lies_straight_ahead(mug_poses):
    mug, poses = mug_poses
    centre, diagonal = bounding_frame(mug)
    intrinsics = poses.intrinsics()
    np.testing.assert_allclose(intrinsics, [[poses.focal_px, 0, 48], [0, poses.focal_px, 48],
                                            [0, 0, 1]])
    assert poses.focal_px == pytest.approx(48 / math.tan(math.radians(22.5)))
    for pose in poses.camera_to_world("opencv"):
        pixels, depths = _project(pose, intrinsics, centre[None, :])
        np.testing.assert_allclose(pixels[0], [48.0, 48.0], atol=1e-9)
        # z, the forward axis, points from the eye at the centre, DISTANCE_FACTOR diagonals away
        to_centre = centre - pose[:3, 3]
        np.testing.assert_allclose(pose[:3, 2], to_centre / np.linalg.norm(to_centre), atol=1e-12)
        assert depths[0] == pytest.approx(DISTANCE_FACTOR * diagonal)


def test_poses_are_rigid_and_opengl_is_opencv_with_y_and_z_flipped(mug_poses):
    _, poses = mug_poses
    opencv = poses.camera_to_world("opencv", up=None)
    opengl = poses.camera_to_world("opengl", up=None)
    assert opencv.shape == opengl.shape == (len(AWKWARD_VIEWS), 4, 4)
    np.testing.assert_allclose(opengl, opencv @ np.diag([1.0, -1.0, -1.0, 1.0]), atol=0)
    for pose in (*opencv, *opengl):
        np.testing.assert_allclose(pose[:3, :3].T @ pose[:3, :3], np.eye(3), atol=1e-12)
        assert np.linalg.det(pose[:3, :3]) == pytest.approx(1.0)
        np.testing.assert_array_equal(pose[3], [0, 0, 0, 1])
    # OpenCV: x right, y down the image (against true up), z forward; OpenGL looks down -z
    np.testing.assert_allclose(opencv[:, :3, 0], poses.right, atol=0)
    np.testing.assert_allclose(opencv[:, :3, 1], -poses.up, atol=0)
    np.testing.assert_allclose(opengl[:, :3, 2], -poses.forward, atol=0)
    np.testing.assert_allclose(opencv[:, :3, 3], poses.eyes, atol=0)


def test_intrinsics_and_pose_project_as_the_measures_camera_does(mug_poses):
    mug, poses = mug_poses
    points = mug.vertices[::7]
    for view, pose in enumerate(poses.camera_to_world("opencv", up=None)):
        pixels, depths = _project(pose, poses.intrinsics(), points)
        expected = poses.project(view, points)
        np.testing.assert_allclose(pixels, expected[:, :2], atol=1e-9)
        np.testing.assert_allclose(depths, expected[:, 2], atol=1e-12)
    # a larger picture of the same view: the same field of view, every pixel scaled
    larger, _ = _project(poses.camera_to_world(up=None)[0], poses.intrinsics(384), points)
    np.testing.assert_allclose(larger, 4.0 * poses.project(0, points)[:, :2], atol=1e-9)


@pytest.mark.parametrize("direction", AWKWARD_VIEWS, ids=["oblique", "up", "down", "behind"])
def test_the_rasteriser_sees_the_face_the_projection_points_at(direction):
    """Through the pixel where K and the pose put a face's centroid, the triangle-ID image sees
    that face, for the front faces of a convex mesh, and a face of the nearest vertex."""
    require_package("trimesh")
    ball = primitive_mesh("icosphere", {"subdivisions": 2, "radius": 1.0}, "ball")
    resolution = 256
    poses = Camera().look_at(ball, [direction], resolution=resolution)
    ids = face_id_images(ball, MeasureSettings(views=1, resolution=resolution),
                         view_directions=[direction])[0]
    pose = poses.camera_to_world("opencv", up=None)[0]
    centroids = ball.vertices[ball.faces].mean(axis=1)
    facing = face_normals(ball) @ poses.forward[0] < -0.5  # well inside the silhouette
    pixels, _ = _project(pose, poses.intrinsics(), centroids[facing])
    columns, rows = np.floor(pixels).astype(int).T  # pixel (col, row) spans [col, col + 1)
    np.testing.assert_array_equal(ids[rows, columns], np.flatnonzero(facing))
    nearest = int(np.argmin(np.linalg.norm(ball.vertices - pose[:3, 3], axis=1)))
    pixel, _ = _project(pose, poses.intrinsics(), ball.vertices[[nearest]])
    column, row = np.floor(pixel[0]).astype(int)
    assert nearest in ball.faces[ids[row, column]]


def test_exported_poses_put_plus_y_up_as_open3d_and_trimesh_do(mug_poses):
    """By default a pose's image up (OpenCV: -y column) leans towards +y; away from the y
    axis this is the measures' camera turned half a turn about its forward axis."""
    mug, poses = mug_poses
    exported = poses.camera_to_world("opencv")
    measured = poses.camera_to_world("opencv", up=None)
    np.testing.assert_array_equal(exported[:, :3, 2:], measured[:, :3, 2:])  # forward, eye
    image_up = -exported[:, :3, 1]
    off_axis = np.abs(poses.forward[:, 1]) < 0.999
    assert (image_up[off_axis, 1] > 0).all()
    half_turn = np.diag([-1.0, -1.0, 1.0, 1.0])
    np.testing.assert_allclose(exported[off_axis], measured[off_axis] @ half_turn, atol=1e-12)
    # a vertex higher in +y is drawn higher in the picture (a smaller row)
    low = mug.vertices[np.argmin(mug.vertices[:, 1])]
    high = mug.vertices[np.argmax(mug.vertices[:, 1])]
    for view in np.flatnonzero(off_axis):
        rows = _project(exported[view], poses.intrinsics(), np.stack([low, high]))[0][:, 1]
        assert rows[1] < rows[0]
    z_up = poses.camera_to_world("opengl", up=(0, 0, 1))
    off_z = np.abs(poses.forward[:, 2]) < 0.999
    assert (z_up[off_z, 2, 1] > 0).all()  # OpenGL: the y column is the image up


def test_a_bad_convention_or_resolution_is_one_line(mug_poses):
    _, poses = mug_poses
    with pytest.raises(InputError, match="^convention: expected one of opencv, opengl, "
                                         "got 'blender'$"):
        poses.camera_to_world("blender")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="^resolution: must be at least 1, got 0$"):
        poses.intrinsics(0)
