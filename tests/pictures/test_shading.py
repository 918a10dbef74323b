"""What both engines share: crease-aware normals and the render style."""

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
