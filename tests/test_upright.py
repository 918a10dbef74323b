"""The up axis of a model: glTF's +y by its format, the resting rule on real z-up and y-up
meshes."""

from __future__ import annotations

import numpy as np
import pytest

from fixtures.paths import ASSETS
from vptoolkit.io import load_mesh
from vptoolkit.samples import sample_path
from vptoolkit.upright import auto_up, footprint_area, resting_up

GAZEBO = ASSETS / "gazebo"
Z_UP = (0.0, 0.0, 1.0)
Y_UP = (0.0, 1.0, 0.0)


@pytest.mark.parametrize("name", ["bus", "construction_cone", "cafe_table", "fire_hydrant"])
def test_z_up_gazebo_models_stand_on_their_z_side(name):
    """A bus on its wheels, a cone, a table on its feet, a hydrant: the rule finds +z."""
    path = GAZEBO / f"{name}.ply"
    assert auto_up(load_mesh(path), path) == Z_UP


def test_a_flat_sign_lies_on_its_face_as_documented():
    """The stop sign stands more broadly on its face: the rule's documented limit."""
    path = GAZEBO / "stop_sign.ply"
    assert auto_up(load_mesh(path), path) == Y_UP


def test_gltf_is_plus_y_by_its_format_and_y_up_scans_stand_on_minus_y():
    duck = sample_path("Duck.glb")
    mesh = load_mesh(duck)
    assert auto_up(mesh, duck) == Y_UP
    # turned z-up, the glTF convention still decides for the file, the geometry without it
    turned = mesh.__class__(mesh.vertices[:, [0, 2, 1]] * [1, -1, 1], mesh.faces[:, ::-1],
                            mesh.name)
    assert auto_up(turned, duck) == Y_UP and auto_up(turned) == Z_UP
    assert resting_up(load_mesh(sample_path("bunny.ply"))) == Y_UP


def test_footprint_is_the_support_polygon_area():
    """A unit cube stands on a unit square whichever side; a tetrahedron on a point has none."""
    cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    assert footprint_area(cube, Z_UP) == pytest.approx(1.0)
    assert footprint_area(cube * [2, 3, 1], Y_UP) == pytest.approx(2.0)
    apex_down = np.array([[0, 0, 0], [1, 0, 1], [-1, 1, 1], [-1, -1, 1]], float)
    assert footprint_area(apex_down, Z_UP) == 0.0
