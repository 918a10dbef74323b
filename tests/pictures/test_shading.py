"""What both engines share: crease-aware normals, the render style, framing and colours."""

from __future__ import annotations

import numpy as np
import pytest

from fixtures.meshes import box_mesh
from vptoolkit.errors import InputError
from vptoolkit.mesh import Mesh
from vptoolkit.pictures.shading import RenderStyle, crease_normals


def test_cube_corners_keep_their_face_normals():
    cube = box_mesh()
    positions, normals, _, face_normals, kept = crease_normals(cube, 40.0)
    assert kept.tolist() == list(range(cube.n_faces))
    assert positions.shape == normals.shape == (3 * cube.n_faces, 3)
    assert positions.dtype == normals.dtype == np.float32
    np.testing.assert_allclose(normals, np.repeat(face_normals, 3, axis=0), atol=1e-6)


def test_sphere_normals_are_smooth():
    import trimesh

    ball = trimesh.creation.icosphere(subdivisions=3)
    sphere = Mesh(ball.vertices, ball.faces, "ball")
    positions, normals, _, _, _ = crease_normals(sphere, 40.0)
    radial = positions / np.linalg.norm(positions, axis=1, keepdims=True)
    angle = np.degrees(np.arccos(np.clip(np.sum(radial * normals, axis=1), -1, 1)))
    assert angle.max() < 2.0  # vertex normals, not the faceted face normals (~ 5 degrees off)
    _, flat, _, _, _ = crease_normals(sphere, 0.0)
    flat_angle = np.degrees(np.arccos(np.clip(np.sum(radial * flat, axis=1), -1, 1)))
    assert flat_angle.max() > 3.0


def test_degenerate_faces_are_not_drawn():
    mesh = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]]),
                np.array([[0, 1, 2], [0, 1, 3]]), "sliver")
    positions, _, face_points, _, kept = crease_normals(mesh, 40.0)
    assert positions.shape == (3, 3) and face_points.shape == (1, 3) and kept.tolist() == [0]


def test_render_style_checks_up():
    with pytest.raises(InputError, match="up: expected a non-zero direction"):
        RenderStyle(up=(0.0, 0.0, 0.0))
    assert RenderStyle(up=(0.0, 0.0, 2.0)).up == (0.0, 0.0, 1.0)


def test_texture_lookup_puts_v_1_at_the_top_row_and_blends_in_linear_light():
    from vptoolkit.pictures.shading import srgb8_to_linear, texture_lookup

    image = np.zeros((2, 2, 4), dtype=np.uint8)
    image[0, 0, :3] = 255  # top-left white, the rest black
    linear = srgb8_to_linear(image[..., :3])
    corners = np.array([[0.25, 0.75], [0.75, 0.75], [0.25, 0.25]])  # texel centres
    np.testing.assert_allclose(texture_lookup(linear, corners)[:, 0], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(texture_lookup(linear, corners, bilinear=False)[:, 0],
                               [1.0, 0.0, 0.0])
    middle = texture_lookup(linear, np.array([[0.5, 0.75]]))[0]
    np.testing.assert_allclose(middle, 0.5)  # half white in linear light, not in sRGB
    wrapped = texture_lookup(linear, np.array([[1.25, -0.25]]))  # REPEAT: the same texel
    np.testing.assert_allclose(wrapped, texture_lookup(linear, np.array([[0.25, 0.75]])))


def test_corner_colors_multiply_what_the_appearance_holds():
    from vptoolkit.appearance import Appearance
    from vptoolkit.pictures.shading import corner_colors

    faces = np.array([[0, 1, 2], [0, 2, 3]])
    assert corner_colors(None, faces, 4) is None
    only_uv = Appearance(corner_uv=np.zeros((2, 3, 2)))  # coordinates without an image
    assert corner_colors(only_uv, faces, 4) is None
    vertex = np.array([[255, 255, 255, 255], [255, 0, 0, 255], [0, 255, 0, 255],
                       [0, 0, 255, 255]], dtype=np.uint8)
    painted = Appearance(vertex_colors=vertex, base_color=np.array([0.5, 1.0, 1.0, 1.0]))
    colours = corner_colors(painted, faces, 4)
    assert colours is not None and colours.shape == (2, 3, 3)
    np.testing.assert_allclose(colours[0, 0], [0.5, 1.0, 1.0])
    np.testing.assert_allclose(colours[1, 2], [0.0, 0.0, 1.0])
    with pytest.raises(InputError, match="face_colors has 1 rows for 2 faces"):
        corner_colors(Appearance(face_colors=vertex[:1]), faces, 4)


def test_frame_zoom_is_one_without_a_margin_and_fits_the_farthest_point():
    from vptoolkit.camera import Camera
    from vptoolkit.pictures.shading import frame_zoom

    poses = Camera().poses([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], centre=np.zeros(3),
                           diagonal=2.0, resolution=100)
    points = np.array([[0.5, 0.0, 0.0], [-0.2, 0.1, 0.0]])
    np.testing.assert_array_equal(frame_zoom(poses, points, None), [1.0, 1.0])
    zoom = frame_zoom(poses, points, 0.1)
    reach = np.abs(poses.project(0, points)[:, :2] - 50.0).max()
    assert zoom[0] * reach == pytest.approx(40.0)  # (1/2 - 0.1) * 100 pixels from the centre
