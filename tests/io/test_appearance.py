"""The readers fill an Appearance beside the geometry: glTF, OBJ + MTL, PLY and OFF colours."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.paths import ASSETS
from vptoolkit.appearance import Appearance
from vptoolkit.errors import InputError, MeshLoadError
from vptoolkit.io import load_mesh, load_with_appearance
from vptoolkit.samples import sample_path


def test_the_duck_keeps_its_base_colour_texture_and_texture_coordinates():
    require_package("PIL")
    mesh, look = load_with_appearance(sample_path("Duck.glb"))
    assert mesh.n_faces == 4212
    assert look.texture is not None and look.texture.shape == (512, 512, 4)
    assert look.corner_uv is not None and look.corner_uv.shape == (mesh.n_faces, 3, 2)
    assert np.isfinite(look.corner_uv).all()
    assert (look.corner_uv >= -1e-6).all() and (look.corner_uv <= 1 + 1e-6).all()
    assert look.base_color is not None and look.base_color.shape == (4,)
    assert look.face_colors is None and look.vertex_colors is None
    # the texture is mostly the duck's yellow: red and green well above blue
    u, v = look.corner_uv.mean(axis=1).T
    rows = np.rint((1 - v) * (look.texture.shape[0] - 1)).astype(int)
    columns = np.rint(u * (look.texture.shape[1] - 1)).astype(int)
    texels = look.texture[rows, columns].astype(float)
    assert np.median(texels[:, 0]) > np.median(texels[:, 2]) + 50


def test_the_milk_truck_has_a_colour_per_face_from_its_materials():
    require_package("PIL")
    mesh, look = load_with_appearance(ASSETS / "real" / "CesiumMilkTruck.glb")
    assert look.face_colors is not None and look.face_colors.shape == (mesh.n_faces, 4)
    assert len(np.unique(look.face_colors, axis=0)) > 1
    assert look.base_color is None
    assert look.texture is not None and look.corner_uv is not None
    assert np.isnan(look.corner_uv).any() and np.isfinite(look.corner_uv).any()


def test_obj_materials_give_a_base_colour_or_one_colour_per_face(tmp_path):
    text = sample_path("table.obj").read_text()
    lines = [line for line in text.splitlines() if not line.startswith(("mtllib", "usemtl"))]
    (tmp_path / "one.mtl").write_text("newmtl wood\nKd 0.5 0.25 0 \nd 0.5\n")
    (tmp_path / "one.obj").write_text("mtllib one.mtl\nusemtl wood\n" + "\n".join(lines) + "\n")
    mesh, look = load_with_appearance(tmp_path / "one.obj")
    np.testing.assert_allclose(look.base_color, [0.5, 0.25, 0.0, 0.5])
    np.testing.assert_array_equal(load_mesh(tmp_path / "one.obj").faces, mesh.faces)
    (tmp_path / "two.mtl").write_text("newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n")
    faces = [line for line in lines if line.startswith("f ")]
    others = [line for line in lines if not line.startswith("f ")]
    half = len(faces) // 2
    body = others + ["usemtl red"] + faces[:half] + ["usemtl blue"] + faces[half:]
    (tmp_path / "two.obj").write_text("mtllib two.mtl\n" + "\n".join(body) + "\n")
    mesh, look = load_with_appearance(tmp_path / "two.obj")
    assert look.base_color is None and look.face_colors is not None
    assert look.face_colors.shape == (mesh.n_faces, 4)
    assert {tuple(row) for row in look.face_colors} == {(255, 0, 0, 255), (0, 0, 255, 255)}


def test_an_obj_texture_and_its_coordinates_are_read(tmp_path):
    require_package("PIL")
    from PIL import Image

    source = sample_path("bottle.obj")  # has vt lines and v/vt faces
    body = [line for line in source.read_text().splitlines()
            if not line.startswith(("mtllib", "usemtl"))]
    Image.new("RGB", (4, 2), (10, 200, 30)).save(tmp_path / "label.png")
    (tmp_path / "bottle.mtl").write_text("newmtl label\nKd 1 1 1\nmap_Kd label.png\n")
    (tmp_path / "bottle.obj").write_text("mtllib bottle.mtl\nusemtl label\n" + "\n".join(body))
    mesh, look = load_with_appearance(tmp_path / "bottle.obj")
    assert look.texture is not None and look.texture.shape == (2, 4, 4)
    assert (look.texture[..., :3] == (10, 200, 30)).all()
    assert look.corner_uv is not None and look.corner_uv.shape == (mesh.n_faces, 3, 2)
    assert np.isfinite(look.corner_uv).all()


def test_a_missing_material_file_is_no_error(tmp_path, caplog):
    shutil.copy(sample_path("table.obj"), tmp_path / "table.obj")
    mesh, look = load_with_appearance(tmp_path / "table.obj")
    assert mesh.n_faces == 12 and look.base_color is None
    assert "table.mtl cannot be read" in caplog.text


def test_ply_vertex_and_face_colours_ascii_and_binary(tmp_path):
    header = ("ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
              "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
              "element face 2\nproperty list uchar int vertex_indices\nproperty uchar red\n"
              "property uchar green\nproperty uchar blue\nend_header\n")
    ascii_body = ("0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 9 9 9\n"
                  "3 0 1 2 200 0 0\n3 0 2 3 0 200 0\n")
    (tmp_path / "quad.ply").write_text(header.format(format="ascii") + ascii_body)
    vertex = np.array([(0, 0, 0, 255, 0, 0), (1, 0, 0, 0, 255, 0), (1, 1, 0, 0, 0, 255),
                       (0, 1, 0, 9, 9, 9)],
                      dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("r", "u1"), ("g", "u1"),
                             ("b", "u1")])
    face = np.array([(3, (0, 1, 2), 200, 0, 0), (3, (0, 2, 3), 0, 200, 0)],
                    dtype=[("n", "u1"), ("i", "<i4", (3,)), ("r", "u1"), ("g", "u1"),
                           ("b", "u1")])
    (tmp_path / "quad_binary.ply").write_bytes(
        header.format(format="binary_little_endian").encode() + vertex.tobytes() + face.tobytes())
    for name in ("quad.ply", "quad_binary.ply"):
        mesh, look = load_with_appearance(tmp_path / name)
        assert mesh.n_faces == 2
        np.testing.assert_array_equal(look.vertex_colors[:, :3],
                                      [[255, 0, 0], [0, 255, 0], [0, 0, 255], [9, 9, 9]])
        assert (look.vertex_colors[:, 3] == 255).all()
        np.testing.assert_array_equal(look.face_colors[:, :3], [[200, 0, 0], [0, 200, 0]])


def test_ply_float_colours_out_of_range_are_refused(tmp_path):
    (tmp_path / "bad.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nproperty float red\nproperty float green\nproperty float blue\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0 1 0 0\n1 0 0 0 2 0\n0 1 0 0 0 1\n3 0 1 2\n")
    with pytest.raises(MeshLoadError, match=r"^bad\.ply: vertex colours outside 0\.\.1"):
        load_mesh(tmp_path / "bad.ply")


def test_coff_colours_and_face_colours(tmp_path):
    (tmp_path / "tri.off").write_text("COFF\n4 2 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n"
                                      "1 1 0 0 0 255 255\n0 1 0 0.5 0.5 0.5 1\n"
                                      "3 0 1 2 1 0 0\n4 0 1 2 3 0 1 0\n")
    with pytest.raises(MeshLoadError, match="vertex colours outside 0..1"):
        load_mesh(tmp_path / "tri.off")  # integers and floats mixed: read as floats
    (tmp_path / "tri.off").write_text("COFF\n4 2 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n"
                                      "1 1 0 0 0 255 255\n0 1 0 9 9 9 255\n"
                                      "3 0 1 2 1 0 0\n4 0 1 2 3 0 1 0\n")
    mesh, look = load_with_appearance(tmp_path / "tri.off")
    assert mesh.n_faces == 3  # the quad is two triangles, with its colour twice
    np.testing.assert_array_equal(look.vertex_colors[3], [9, 9, 9, 255])
    np.testing.assert_array_equal(look.face_colors[:, :3], [[1, 0, 0], [0, 1, 0], [0, 1, 0]])


def test_a_point_cloud_ply_keeps_its_point_colours(tmp_path):
    rows = np.random.default_rng(0).random((50, 3))
    colours = (rows * 255).astype(int)
    body = "".join(f"{x} {y} {z} {r} {g} {b}\n" for (x, y, z), (r, g, b) in zip(rows, colours))
    (tmp_path / "scan.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 50\nproperty double x\nproperty double y\n"
        "property double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
        "end_header\n" + body)
    cloud, look = load_with_appearance(tmp_path / "scan.ply")
    assert cloud.n_points == 50 and look.face_colors is None
    np.testing.assert_array_equal(look.vertex_colors[:, :3], colours)


def test_an_appearance_checks_its_arrays():
    assert Appearance().is_empty
    with pytest.raises(InputError, match=r"face_colors must be \(n, 4\) uint8"):
        Appearance(face_colors=np.zeros((3, 3), np.uint8))
    look = Appearance(base_color=np.ones(4))
    with pytest.raises(ValueError):
        look.base_color[0] = 0.0
