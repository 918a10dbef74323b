"""load_mesh, save_mesh and find_mesh_files over every format (OFF, OBJ, PLY, STL, glTF),
with trimesh's malformed test models."""

from __future__ import annotations

import base64
import json
import os
import re
import struct
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from fixtures.paths import MALFORMED
from vptoolkit.errors import InputError, MeshLoadError
from vptoolkit.io import (
    SUPPORTED_SUFFIXES,
    WRITABLE_SUFFIXES,
    find_mesh_files,
    load_mesh,
    save_mesh,
)
from vptoolkit.mesh import Mesh
from vptoolkit.samples import sample_path

# file -> (n_vertices, n_faces) when it loads, or a regex the message must match
MALFORMED_OUTCOMES: dict[str, tuple[int, int] | str] = {
    "busted.STL": (11634, 3878),
    "comments.off": (8, 12),
    "empty.obj": r"^empty\.obj: no geometry \(no vertices, no faces\)$",
    "empty.stl": r"^empty\.stl: no geometry \(no vertices, no faces\)$",
    "nancolor.obj": (8, 12),
    "negative_indices.obj": (8, 12),
    "notenoughindices.obj": (3, 1),
    "ply_empty_header.ply": r"^ply_empty_header\.ply: no geometry \(no vertices, no faces\)$",
    "polygonfaces.obj": (5, 3),
    "soup.stl": (300, 100),
    "whitespace.off": (8, 12),
}

CUBE_VERTICES = np.array(
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
    dtype=np.float64,
)
CUBE_QUADS = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]
CUBE_TRIANGLES = np.array(
    [[q[0], q[1], q[2]] for q in CUBE_QUADS] + [[q[0], q[2], q[3]] for q in CUBE_QUADS],
    dtype=np.int64,
)


def cube_off(header: str = "OFF\n8 12 0\n") -> str:
    """Return OFF text of the unit cube as 12 triangles after ``header``."""
    vertices = "".join(f"{x:g} {y:g} {z:g}\n" for x, y, z in CUBE_VERTICES)
    faces = "".join(f"3 {a} {b} {c}\n" for a, b, c in CUBE_TRIANGLES)
    return header + vertices + faces


def write(directory: Path, name: str, content: str | bytes) -> Path:
    path = directory / name
    if isinstance(content, str):
        path.write_text(content, encoding="utf-8")
    else:
        path.write_bytes(content)
    return path


def load_error(path: Path) -> str:
    """Load ``path``, expect a MeshLoadError and return its checked message."""
    with pytest.raises(MeshLoadError) as info:
        load_mesh(path)
    message = str(info.value)
    assert message.startswith(f"{path.name}: "), message
    assert "\n" not in message
    return message


def canonical_triangles(corners: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotate each ``(n, 3, 3)`` triangle to start at its smallest corner, then sort rows.

    Keeps the winding, so two meshes with the same oriented triangles compare equal
    whatever the face order, the first corner of each face or the vertex sharing.
    """
    order = np.lexsort((corners[:, :, 2], corners[:, :, 1], corners[:, :, 0]), axis=-1)
    roll = (order[:, :1] + np.arange(3)) % 3
    rotated = np.take_along_axis(corners, roll[:, :, None], axis=1).reshape(-1, 9)
    return rotated[np.lexsort(rotated.T[::-1])]


@pytest.mark.parametrize(
    "name", ["ballA.off", "bunny.ply", "suzanne.ply", "mug.obj", "lego.obj", "teapot.stl"]
)
def test_sample_triangles_match_trimesh(name: str) -> None:
    import trimesh
    path = sample_path(name)
    scene = trimesh.load_scene(str(path), process=False, skip_materials=True)
    expected = np.concatenate(
        [geometry.vertices[geometry.faces] for geometry in scene.geometry.values()]
    )
    mesh = load_mesh(path)
    got = mesh.vertices[mesh.faces]
    assert got.shape == expected.shape
    np.testing.assert_allclose(canonical_triangles(got), canonical_triangles(expected))


def test_obj_vertices_keep_file_order() -> None:
    path = sample_path("mug.obj")
    rows = [line.split()[1:4] for line in path.read_text().splitlines() if line.startswith("v ")]
    mesh = load_mesh(path)
    np.testing.assert_array_equal(mesh.vertices, np.array(rows, dtype=np.float64))


def test_glb_scene_transforms_are_applied() -> None:
    import trimesh
    path = sample_path("Duck.glb")
    scene = trimesh.load_scene(str(path))
    raw = next(iter(scene.geometry.values()))
    flattened = scene.to_mesh()
    mesh = load_mesh(path)
    assert not np.allclose(raw.bounds, flattened.bounds)  # the node scales the duck
    bounds = np.stack([mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)])
    np.testing.assert_allclose(bounds, flattened.bounds, rtol=1e-12)
    np.testing.assert_allclose(mesh.vertices, flattened.vertices, rtol=1e-12)
    np.testing.assert_array_equal(mesh.faces, flattened.faces)


def test_every_malformed_file_has_an_expected_outcome() -> None:
    files = {
        path.name for path in MALFORMED.iterdir() if path.suffix.lower() in SUPPORTED_SUFFIXES
    }
    assert files == set(MALFORMED_OUTCOMES)


@pytest.mark.parametrize("name", sorted(MALFORMED_OUTCOMES))
def test_malformed_file_outcome(name: str) -> None:
    expected = MALFORMED_OUTCOMES[name]
    path = MALFORMED / name
    if isinstance(expected, str):
        assert re.search(expected, load_error(path))
        return
    mesh = load_mesh(path)
    assert (mesh.n_vertices, mesh.n_faces) == expected
    assert np.isfinite(mesh.vertices).all()


def test_negative_obj_indices_count_back_from_the_last_vertex() -> None:
    mesh = load_mesh(MALFORMED / "negative_indices.obj")
    # f -8 -4 -2 -6 with 8 vertices defined -> 0 4 6 2
    np.testing.assert_array_equal(mesh.faces[:2], [[0, 4, 6], [0, 6, 2]])
    np.testing.assert_array_equal(mesh.vertices[0], [1, 1, -1])


def test_polygon_obj_face_is_fan_triangulated() -> None:
    mesh = load_mesh(MALFORMED / "polygonfaces.obj")
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3], [0, 3, 4]])


def test_two_vertex_obj_face_is_skipped() -> None:
    mesh = load_mesh(MALFORMED / "notenoughindices.obj")
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2]])


def test_nan_vertex_colour_is_ignored() -> None:
    mesh = load_mesh(MALFORMED / "nancolor.obj")
    np.testing.assert_array_equal(mesh.vertices[6], [0.5, 0.5, -0.5])


def test_odd_whitespace_off_equals_commented_off() -> None:
    commented = load_mesh(MALFORMED / "comments.off")
    indented = load_mesh(MALFORMED / "whitespace.off")
    np.testing.assert_array_equal(commented.vertices, indented.vertices)
    np.testing.assert_array_equal(commented.faces, indented.faces)
    np.testing.assert_array_equal(commented.faces[0], [0, 1, 2])
    np.testing.assert_array_equal(commented.faces[1], [0, 2, 3])


@pytest.mark.parametrize(
    "header",
    [
        "OFF8 12 0\n",
        "OFF 8 12 0\n",
        "OFF\n8 12 0\n",
        "# comment\n\nOFF\n# counts\n8 12\n",
        "\t  OFF8 12 0 # x\n",
    ],
    ids=["glued", "same-line", "two-lines", "comments-no-edge-count", "indented-glued"],
)
def test_off_headers_load_the_same_cube(tmp_path: Path, header: str) -> None:
    mesh = load_mesh(write(tmp_path, "cube.off", cube_off(header)))
    np.testing.assert_array_equal(mesh.vertices, CUBE_VERTICES)
    np.testing.assert_array_equal(mesh.faces, CUBE_TRIANGLES)
    assert mesh.name == "cube"


def test_off_quads_with_colours_are_triangulated(tmp_path: Path) -> None:
    vertices = "".join(f"{x:g} {y:g} {z:g} 0.5 0.5 0.5\n" for x, y, z in CUBE_VERTICES)
    faces = "".join(f"4 {a} {b} {c} {d} 255 0 0\n" for a, b, c, d in CUBE_QUADS)
    mesh = load_mesh(write(tmp_path, "quads.off", "COFF\n8 6 0\n" + vertices + faces))
    assert mesh.n_faces == 12
    np.testing.assert_array_equal(mesh.faces[:2], [[0, 3, 2], [0, 2, 1]])


def test_off_mixed_polygons_keep_file_order(tmp_path: Path) -> None:
    text = "OFF\n5 3 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n3 0 1 4\n4 0 1 2 3\n3 1 2 4\n"
    mesh = load_mesh(write(tmp_path, "mixed.off", text))
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 4], [0, 1, 2], [0, 2, 3], [1, 2, 4]])


def test_off_unused_vertices_are_kept(tmp_path: Path) -> None:
    text = "OFF\n5 1 0\n0 0 0\n1 0 0\n0 1 0\n9 9 9\n8 8 8\n3 0 1 2\n"
    mesh = load_mesh(write(tmp_path, "unused.off", text))
    assert (mesh.n_vertices, mesh.n_faces) == (5, 1)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (cube_off("OFF\n8 13 0\n"), r"^chair\.off: header declares 13 faces, file has 12$"),
        (cube_off("OFF\n9 11 0\n"), r"^chair\.off: line 11: vertex has 4 values, the first has 3 \(does the header count the vertices right\?\)$"),
        (cube_off("OFF\n7 13 0\n"), r"^chair\.off: line 10: face has 0 vertices, need at least 3$"),
        ("OFF\n8 12 0\n0 0 0\n", r"^chair\.off: header declares 8 vertices, file has 1$"),
        (cube_off("OFF\n8 11 0\n"), r"^chair\.off: line 22: unexpected data after the 8 vertices and 11 faces"),
        (cube_off().replace("3 2 3 7", "3 2 3 8"), r"^chair\.off: face \d+ refers to vertex 8, file has 8 vertices$"),
        (cube_off().replace("3 2 3 7", "3 2 3 -1"), r"^chair\.off: face \d+ refers to vertex -1, file has 8 vertices$"),
        (cube_off().replace("1 1 1", "1 nan 1"), r"^chair\.off: 1 vertex has NaN or infinite coordinates \(first: vertex 6\)$"),
        (cube_off().replace("1 1 1", "1 1e999 1"), r"^chair\.off: 1 vertex has NaN or infinite"),
        (cube_off().replace("1 1 1", "1 one 1"), r"^chair\.off: line 9: cannot read vertex coordinates '1 one 1'$"),
        (cube_off().replace("1 1 1", "1 1"), r"^chair\.off: line 9: vertex needs 3 coordinates, found 2$"),
        (cube_off().replace("3 2 3 7", "3 2 3 7.5"), r"^chair\.off: line \d+: face index '7\.5' is not an integer$"),
        (cube_off().replace("3 2 3 7", "x 2 3 7"), r"^chair\.off: line \d+: expected the face's vertex count, found 'x'$"),
        (cube_off("OFF\n8 twelve 0\n"), r"^chair\.off: line 2: expected 'n_vertices n_faces n_edges', found '8 twelve 0'$"),
        (cube_off("OFF\n"), r"^chair\.off: line 3: unexpected data after the 0 vertices and 0 faces the header declares$"),
        ("OFF\n", r"^chair\.off: header has no vertex and face counts$"),
        ("# only a comment\n\n", r"^chair\.off: no geometry \(only comments and blank lines\)$"),
        (cube_off("ply\n8 12 0\n"), r"^chair\.off: line 1: expected the OFF keyword, found 'ply'$"),
        (cube_off("4OFF\n8 12 0\n"), r"^chair\.off: line 1: expected the OFF keyword"),
        (cube_off("nOFF\n8 12 0\n"), r"^chair\.off: unsupported OFF variant 'nOFF'$"),
        ("OFF BINARY\n\0\0\0\x08", r"^chair\.off: binary OFF is not supported$"),
        ("OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", r"^chair\.off: a point cloud \(3 points, no faces\); this needs a surface"),
        ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", r"^chair\.off: line 6: face has 2 vertices, need at least 3$"),
        ("OFF\n0 0 0\n", r"^chair\.off: no geometry \(no vertices, no faces\)$"),
    ],
    ids=[
        "too-few-faces", "vertex-count-high", "vertex-count-low", "too-few-vertices",
        "extra-lines", "index-too-large", "negative-index", "nan", "inf", "bad-float", "short-vertex", "float-index", "bad-count",
        "bad-header", "missing-counts", "header-only", "comments-only", "wrong-keyword", "4off",
        "noff", "binary", "no-faces", "only-lines", "zero-counts",
    ],
)  # fmt: skip
def test_bad_off_fails_clearly(tmp_path: Path, text: str, message: str) -> None:
    assert re.search(message, load_error(write(tmp_path, "chair.off", text)))


def test_obj_relative_indices_count_from_the_current_vertex(tmp_path: Path) -> None:
    text = (
        "o first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
        "o second\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3/1/1 -2/2/2 -1/3/3\nf 1 2 6\n"
    )
    mesh = load_mesh(write(tmp_path, "two.obj", text))
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [3, 4, 5], [0, 1, 5]])


def test_obj_line_continuation_and_comments(tmp_path: Path) -> None:
    text = "# cube corner\nv 0 0 0\nv 1 0 \\\n 0\nv 0 1 0 # third\nf 1 2 \\\n 3\n"
    mesh = load_mesh(write(tmp_path, "cont.obj", text))
    np.testing.assert_array_equal(mesh.vertices, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2]])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", r"^bad\.obj: line 4: face index 9 out of range, file has 3 vertices$"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", r"^bad\.obj: line 4: face index 0 is invalid \(OBJ indices start at 1\)$"),
        ("v 0 0 0\nv 1 0 0\nf -3 -2 -1\nv 0 1 0\n", r"^bad\.obj: line 3: relative face index -3 reaches before the first vertex \(2 vertices defined so far\)$"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 b 3\n", r"^bad\.obj: line 4: cannot read face 'f 1 b 3'$"),
        ("v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", r"^bad\.obj: line 2: vertex needs 3 coordinates, found 2$"),
        ("v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n", r"^bad\.obj: 1 vertex has NaN or infinite coordinates \(first: vertex 1\)$"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n", r"^bad\.obj: a point cloud \(3 points, no faces\); this needs a surface"),
        ("mtllib missing.mtl\nusemtl x\n", r"^bad\.obj: no geometry"),
    ],
    ids=[
        "index-too-large", "index-zero", "relative-too-far", "bad-index", "short-vertex", "inf",
        "points-only", "no-geometry",
    ],
)  # fmt: skip
def test_bad_obj_fails_clearly(tmp_path: Path, text: str, message: str) -> None:
    assert re.search(message, load_error(write(tmp_path, "bad.obj", text)))


PLY_HEADER = (
    "ply\nformat {format} 1.0\ncomment made by a test\nelement vertex {n_vertices}\n"
    "property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
    "element face {n_faces}\nproperty list uchar int vertex_indices\nend_header\n"
)


def ply_ascii(n_vertices: int = 5, n_faces: int = 2, body: str | None = None) -> str:
    if body is None:
        body = "0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n0 0 1 5\n4 0 1 2 3\n3 0 1 4\n"
    return PLY_HEADER.format(format="ascii", n_vertices=n_vertices, n_faces=n_faces) + body


def ply_binary(byte_order: str, polygons: list[list[int]]) -> bytes:
    """Binary PLY of the 5 vertices in :func:`ply_ascii` with the given polygons."""
    name = {"<": "binary_little_endian", ">": "binary_big_endian"}[byte_order]
    header = PLY_HEADER.format(format=name, n_vertices=5, n_faces=len(polygons)).encode()
    vertex_dtype = np.dtype([("xyz", byte_order + "f4", (3,)), ("red", "u1")])
    vertices = np.zeros(5, dtype=vertex_dtype)
    vertices["xyz"] = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1]]
    faces = b"".join(
        struct.pack(f"{byte_order}B{len(p)}i", len(p), *p) for p in polygons
    )
    return header + vertices.tobytes() + faces


def test_ascii_ply_polygons(tmp_path: Path) -> None:
    mesh = load_mesh(write(tmp_path, "quad.ply", ply_ascii()))
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3], [0, 1, 4]])
    np.testing.assert_array_equal(mesh.vertices[4], [0, 0, 1])


@pytest.mark.parametrize("byte_order", ["<", ">"], ids=["little-endian", "big-endian"])
@pytest.mark.parametrize(
    "polygons", [[[0, 1, 2], [0, 1, 4]], [[0, 1, 2, 3], [0, 1, 4]]], ids=["triangles", "mixed"]
)
def test_binary_ply(tmp_path: Path, byte_order: str, polygons: list[list[int]]) -> None:
    mesh = load_mesh(write(tmp_path, "bin.ply", ply_binary(byte_order, polygons)))
    if len(polygons[0]) == 3:
        expected = [[0, 1, 2], [0, 1, 4]]
    else:
        expected = [[0, 1, 2], [0, 2, 3], [0, 1, 4]]
    np.testing.assert_array_equal(mesh.faces, expected)
    np.testing.assert_array_equal(mesh.vertices[1], [1, 0, 0])


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (ply_ascii(n_faces=3), r"^bad\.ply: PLY header declares 3 faces, file has 2$"),
        (ply_ascii(n_vertices=6), r"^bad\.ply: line 17: vertex row has 5 values, expected 4$"),
        (ply_ascii(n_vertices=4), r"^bad\.ply: line 16: face declares 0 vertices but lists 3 values$"),
        (ply_ascii(n_faces=1), r"^bad\.ply: line 18: unexpected data after the last PLY element$"),
        (ply_ascii(body="0 0 0 1\n" * 5 + "4 0 1 2\n3 0 1 4\n"), r"^bad\.ply: line 17: face declares 4 vertices but lists 3 values$"),
        (ply_ascii(body="0 0 0 1\n" * 5 + "3 0 1 7\n3 0 1 4\n"), r"^bad\.ply: face 0 refers to vertex 7, file has 5 vertices$"),
        (ply_ascii(body="0 0 0 1\n" * 5 + "3 0 1 -2\n3 0 1 4\n"), r"^bad\.ply: face 0 refers to vertex -2, file has 5 vertices$"),
        (ply_ascii(body="0 0 nan 1\n" * 5 + "3 0 1 2\n3 0 1 4\n"), r"^bad\.ply: 5 vertices have NaN or infinite coordinates"),
        (ply_ascii(n_faces=0, body="0 0 0 1\n" * 5), r"^bad\.ply: its 5 point\(s\) lie on one line"),
        (ply_ascii().replace("end_header\n", ""), r"^bad\.ply: PLY header has no end_header line$"),
        (ply_ascii().replace("format ascii", "format binary"), r"^bad\.ply: PLY header line 2 is invalid: 'format binary 1\.0'$"),
        (ply_ascii().replace("property float z\n", ""), r"^bad\.ply: PLY vertex element has no z property$"),
        (ply_ascii().replace("vertex_indices", "corners"), r"^bad\.ply: PLY face element has no vertex_indices list$"),
        (ply_binary("<", [[0, 1, 2], [0, 1, 4]])[:-5], r"^bad\.ply: PLY file ends before the 2 faces its header declares$"),
        (ply_binary("<", [[0, 1, 2, 3], [0, 1, 4]])[:-1], r"^bad\.ply: PLY file ends before the 2 faces its header declares$"),
        (ply_binary("<", [[0, 1, 2], [0, 1, 4]]) + b"junk", r"^bad\.ply: 4 bytes of unexpected data after the last PLY element$"),
        (ply_binary("<", [[0, 1, 2]]).replace(b"element vertex 5", b"element vertex 9"), r"^bad\.ply: PLY file ends before the 9 vertices its header declares$"),
        (b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 8, r"^bad\.ply: not a PLY file \(it does not start with 'ply'\)$"),
    ],
    ids=[
        "too-few-faces", "too-few-vertices", "count-shift", "extra-rows", "short-face",
        "index-too-large", "negative-index", "nan", "point-cloud", "no-end-header", "bad-format",
        "no-z", "no-indices", "binary-truncated", "binary-mixed-truncated", "binary-trailing-junk",
        "binary-count-shift", "png",
    ],
)  # fmt: skip
def test_bad_ply_fails_clearly(tmp_path: Path, content: str | bytes, message: str) -> None:
    assert re.search(message, load_error(write(tmp_path, "bad.ply", content)))


def binary_stl(corners: NDArray[np.float64], header: bytes = b"") -> bytes:
    records = np.zeros(len(corners), dtype=[("n", "<f4", (3,)), ("c", "<f4", (3, 3)), ("a", "<u2")])
    records["c"] = corners
    return header.ljust(80, b" ") + struct.pack("<I", len(corners)) + records.tobytes()


TRIANGLE = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], dtype=np.float64)


def test_binary_stl_whose_header_starts_with_solid(tmp_path: Path) -> None:
    mesh = load_mesh(write(tmp_path, "cad.stl", binary_stl(TRIANGLE, b"solid exported by CAD")))
    np.testing.assert_array_equal(mesh.vertices, TRIANGLE[0])
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2]])


def test_ascii_stl_with_two_solids(tmp_path: Path) -> None:
    facet = (
        "facet normal 0 0 1\n outer loop\n  vertex 0 0 {z}\n  vertex 1 0 {z}\n"
        "  vertex 0 1 {z}\n endloop\nendfacet\n"
    )
    first, second = facet.format(z=0), facet.format(z=2).upper()
    text = f"solid a\n{first}endsolid a\nSOLID B\n{second}ENDSOLID B\n"
    mesh = load_mesh(write(tmp_path, "two.STL", text))
    assert (mesh.n_vertices, mesh.n_faces) == (6, 2)
    np.testing.assert_array_equal(mesh.vertices[3:], TRIANGLE[0] + [0, 0, 2])


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (binary_stl(np.repeat(TRIANGLE, 100, axis=0))[:584], r"^bad\.stl: binary STL header declares 100 triangles \(5084 bytes\), file has 584 bytes$"),
        (bytes(84), r"^bad\.stl: no geometry \(no vertices, no faces\)$"),
        (b"\x01" * 40, r"^bad\.stl: not an STL file \(binary STL needs 84\+ bytes, file has 40\)$"),
        ("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n", r"^bad\.stl: ASCII STL has 2 vertex lines, not a multiple of 3$"),
        ("solid x\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 zero\nendsolid\n", r"^bad\.stl: cannot read STL vertex '0 1 zero'$"),
        (binary_stl(TRIANGLE * np.nan), r"^bad\.stl: 3 vertices have NaN or infinite coordinates"),
    ],
    ids=["truncated-binary", "zero-triangles", "too-short", "truncated-ascii", "bad-number", "nan"],
)  # fmt: skip
def test_bad_stl_fails_clearly(tmp_path: Path, content: str | bytes, message: str) -> None:
    assert re.search(message, load_error(write(tmp_path, "bad.stl", content)))


def gltf_with_two_instances(second_node: dict[str, object]) -> str:
    """glTF JSON with one triangle, instanced by an identity node and ``second_node``."""
    positions = TRIANGLE[0].astype("<f4").tobytes()
    indices = np.array([0, 1, 2, 0], dtype="<u2").tobytes()  # padded to 4 bytes
    buffer = positions + indices
    document = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"mesh": 0, **second_node}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [
            {
                "byteLength": len(buffer),
                "uri": "data:application/octet-stream;base64," + base64.b64encode(buffer).decode(),
            }
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 6},
        ],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": 3,
                "type": "VEC3",
                "min": [0, 0, 0],
                "max": [1, 1, 0],
            },
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
        ],
    }
    return json.dumps(document)


def test_gltf_instances_are_transformed(tmp_path: Path) -> None:
    second_node = {"translation": [0, 0, 5], "scale": [2, 2, 2]}
    path = write(tmp_path, "pair.gltf", gltf_with_two_instances(second_node))
    mesh = load_mesh(path)
    assert mesh.n_faces == 2
    corners = np.sort(mesh.vertices[mesh.faces].reshape(-1, 3), axis=0)
    np.testing.assert_allclose(corners[-1], [2, 2, 5])
    expected = np.concatenate([TRIANGLE[0], 2 * TRIANGLE[0] + [0, 0, 5]])
    np.testing.assert_allclose(
        canonical_triangles(mesh.vertices[mesh.faces]),
        canonical_triangles(expected.reshape(2, 3, 3)),
    )


def test_gltf_mirroring_node_keeps_triangles_facing_out(tmp_path: Path) -> None:
    path = write(tmp_path, "mirror.gltf", gltf_with_two_instances({"scale": [-1, 1, 1]}))
    mesh = load_mesh(path)
    corners = mesh.vertices[mesh.faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    np.testing.assert_allclose(normals, [[0, 0, 1], [0, 0, 1]])  # mirrored in x, still +z
    expected = np.stack([TRIANGLE[0], (TRIANGLE[0] * [-1, 1, 1])[::-1]])  # winding reversed
    np.testing.assert_allclose(canonical_triangles(corners), canonical_triangles(expected))


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("bad.gltf", "{not json", r"^bad\.gltf: invalid glTF JSON \("),
        ("bad.gltf", '{"asset": {"version": "2.0"}}', r"^bad\.gltf: no geometry \(no vertices, no faces\)$"),
        ("bad.glb", b"PK\x03\x04" + bytes(100), r"^bad\.glb: not a GLB file \(it does not start with 'glTF'\)$"),
        ("bad.glb", b"glTF" + bytes(100), r"^bad\.glb: cannot parse GLB file \(\w+: "),
        (
            "bad.gltf",
            gltf_with_two_instances({}).replace(
                '"count": 3, "type": "SCALAR"', '"count": 300, "type": "SCALAR"'
            ),
            r"^bad\.gltf: cannot parse glTF file \(\w+: ",
        ),
    ],
    ids=["bad-json", "no-meshes", "zip-bytes", "glb-garbage", "accessor-too-long"],
)
def test_bad_gltf_fails_clearly(
    tmp_path: Path, name: str, content: str | bytes, message: str
) -> None:
    assert re.search(message, load_error(write(tmp_path, name, content)))


def test_missing_file(tmp_path: Path) -> None:
    message = load_error(tmp_path / "chair.off")
    assert message == f"chair.off: no such file: {tmp_path / 'chair.off'}"


def test_missing_parent_directory(tmp_path: Path) -> None:
    assert "no such file" in load_error(tmp_path / "nowhere" / "chair.obj")


def test_directory(tmp_path: Path) -> None:
    (tmp_path / "models.off").mkdir()
    assert load_error(tmp_path / "models.off") == "models.off: is a directory, not a mesh file"


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
def test_named_pipe_is_rejected_without_blocking(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "pipe.off")
    assert load_error(tmp_path / "pipe.off") == "pipe.off: not a regular file"


@pytest.mark.parametrize("name", ["chair.abc", "chair", "chair.off.gz"])
def test_unknown_suffix(tmp_path: Path, name: str) -> None:
    message = load_error(write(tmp_path, name, cube_off()))
    found = r": (unknown suffix '\.\w+'|no file suffix); supported: \.off, \.obj, "
    assert re.search(found, message)


@pytest.mark.parametrize("suffix", SUPPORTED_SUFFIXES)
def test_zero_bytes(tmp_path: Path, suffix: str) -> None:
    path = write(tmp_path, f"empty{suffix}", b"")
    assert load_error(path) == f"empty{suffix}: file is empty (0 bytes)"


@pytest.mark.parametrize("suffix", SUPPORTED_SUFFIXES + (".STL", ".OFF"))
def test_garbage_bytes(tmp_path: Path, suffix: str) -> None:
    garbage = np.random.default_rng(7).integers(0, 256, size=20_000, dtype=np.uint8).tobytes()
    load_error(write(tmp_path, f"noise{suffix}", garbage))


def test_upper_case_suffix_is_read(tmp_path: Path) -> None:
    mesh = load_mesh(write(tmp_path, "CUBE.OFF", cube_off()))
    assert (mesh.name, mesh.n_faces) == ("CUBE", 12)


def test_path_must_be_path_like() -> None:
    with pytest.raises(InputError, match=r"^path: expected a str or os\.PathLike, got int$"):
        load_mesh(3)  # type: ignore[arg-type]


def test_parser_failure_chains_the_cause(tmp_path: Path) -> None:
    with pytest.raises(MeshLoadError) as info:
        load_mesh(write(tmp_path, "bad.gltf", "{not json"))
    assert isinstance(info.value.__cause__, ValueError)
    assert isinstance(info.value, ValueError)  # MeshLoadError is an InputError/ValueError


@pytest.fixture(scope="module")
def suzanne() -> Mesh:
    return load_mesh(sample_path("suzanne.ply"))


@pytest.mark.parametrize("suffix", [".off", ".obj", ".ply"])
def test_save_load_round_trip_is_exact(tmp_path: Path, suzanne: Mesh, suffix: str) -> None:
    path = save_mesh(suzanne, tmp_path / f"copy{suffix}")
    assert path == tmp_path / f"copy{suffix}"
    loaded = load_mesh(path)
    assert loaded.name == "copy"
    np.testing.assert_array_equal(loaded.vertices, suzanne.vertices)
    np.testing.assert_array_equal(loaded.faces, suzanne.faces)


def test_save_stl_writes_float32_triangle_soup(tmp_path: Path, suzanne: Mesh) -> None:
    loaded = load_mesh(save_mesh(suzanne, tmp_path / "copy.STL"))
    assert loaded.n_faces == suzanne.n_faces
    expected = suzanne.vertices[suzanne.faces].reshape(-1, 3).astype(np.float32)
    np.testing.assert_array_equal(loaded.vertices, expected)
    assert (tmp_path / "copy.STL").stat().st_size == 84 + 50 * suzanne.n_faces


def test_save_replaces_an_existing_file_and_leaves_no_temporaries(
    tmp_path: Path, suzanne: Mesh
) -> None:
    target = write(tmp_path, "mesh.off", "old content")
    save_mesh(suzanne, target)
    assert load_mesh(target).n_faces == suzanne.n_faces
    assert sorted(path.name for path in tmp_path.iterdir()) == ["mesh.off"]
    assert set(WRITABLE_SUFFIXES) <= set(SUPPORTED_SUFFIXES)


@pytest.mark.parametrize(
    ("name", "message"),
    [("copy.glb", r"^copy\.glb: cannot write \.glb; supported: \.off, \.ply, \.obj, \.stl$"),
     ("copy", r"^copy: cannot write files without a suffix"),
     ("missing/copy.off", r"^copy\.off: target directory does not exist: ")],
)  # fmt: skip
def test_save_rejects_bad_targets(tmp_path: Path, suzanne: Mesh, name: str, message: str) -> None:
    with pytest.raises(InputError, match=message):
        save_mesh(suzanne, tmp_path / name)
    assert not any(tmp_path.glob("*.tmp")) and not any(tmp_path.glob(".*"))


def test_save_rejects_non_mesh(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"^mesh: expected a vptoolkit Mesh, .* or \(vertices, faces\), got ndarray$"):
        save_mesh(np.zeros((3, 3)), tmp_path / "x.off")  # type: ignore[arg-type]


def test_find_mesh_files_skips_hidden_files_and_folders_and_sorts(tmp_path: Path) -> None:
    root = tmp_path / ".cache" / "meshes"  # a hidden root is still searched
    for relative in ["b/z.off", "b/a.PLY", "a.stl", "b/c/d.obj", "notes.txt", ".partial.off",
                     ".git/x.off", "b/.hidden/y.obj", "b/c/.e.glb"]:
        (root / relative).parent.mkdir(parents=True, exist_ok=True)
        (root / relative).write_bytes(b"")
    found = find_mesh_files(root)
    assert [p.relative_to(root).as_posix() for p in found] == [
        "a.stl", "b/a.PLY", "b/c/d.obj", "b/z.off"
    ]
    assert found == sorted(found)
    assert find_mesh_files(str(root)) == found


def test_find_mesh_files_needs_a_folder(tmp_path: Path) -> None:
    (tmp_path / "a.off").write_bytes(b"")
    with pytest.raises(InputError, match="a.off: not a folder"):
        find_mesh_files(tmp_path / "a.off")
    with pytest.raises(InputError, match="missing: not a folder"):
        find_mesh_files(tmp_path / "missing")
