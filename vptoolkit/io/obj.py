"""Read and write the vertices and faces of Wavefront OBJ files."""

from __future__ import annotations

import logging
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import one_line
from vptoolkit.io._polygons import FormatError, Reading, parse_floats, plural, polygon_of
from vptoolkit.io.images import read_image
from vptoolkit.io.ply import file_label

_log = logging.getLogger(__name__)

__all__ = ["obj_bytes", "read_obj"]


def read_obj(data: bytes, folder: Path | None = None) -> Reading:
    """Read the ``v``, ``vt``, ``f``, ``mtllib`` and ``usemtl`` statements of a Wavefront OBJ file.

    Indices are 1-based; negative ones count back from the last vertex (or
    texture coordinate) defined so far. Faces keep the vertex part of
    ``v/vt/vn`` and the texture part as per-corner texture coordinates;
    normals, lines and points are ignored. A backslash at the end of a line
    continues it, and ``#`` starts a comment. A file of ``v`` lines and no
    faces is a point cloud.

    Materials come from the ``mtllib`` files beside the OBJ (``newmtl``, ``Kd``,
    ``d``, ``map_Kd``): one material gives the base colour, several give each
    face its material's ``Kd``; the image of the first textured material used
    is the texture (the corners of faces with another material get NaN
    coordinates, and a warning says so). A missing material file is a
    warning, not an error: the geometry does not depend on it.

    Parameters
    ----------
    data : bytes
        The whole file, UTF-8 (undecodable bytes are replaced).
    folder : Path, optional
        Where ``mtllib`` and texture files are looked up; None reads no
        materials (default: None).

    Returns
    -------
    Reading
        Coordinates in file order without merging or splitting, the faces as
        ``(flat_indices, sizes)`` in file order (indices 0-based), per-corner
        texture coordinates when any face has them, and the material colours
        and texture.

    Raises
    ------
    FormatError
        If a vertex, texture coordinate or face cannot be read or an index is
        out of range.
    """
    text = data.decode("utf-8", errors="replace")
    if "\\" in text:  # line continuation
        text = re.sub(r"\\[ \t]*\r?\n", " ", text)
    vertex_rows: list[list[str]] = []
    vertex_numbers: list[int] = []
    uv_rows: list[list[str]] = []
    uv_numbers: list[int] = []
    face_indices: list[int] = []
    face_uv: list[int] = []  # 0 where a corner has no texture index
    face_sizes: list[int] = []
    face_numbers: list[int] = []
    face_materials: list[str] = []
    n_defined: list[int] = []  # vertices defined before each face
    uv_defined: list[int] = []  # texture coordinates defined before each face
    libraries: list[str] = []
    material = ""
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.lstrip()
        head = line[:2]
        if head not in ("v ", "v\t", "f ", "f\t", "vt", "us", "mt"):
            continue
        tokens = line.partition("#")[0].split()
        if not tokens:
            continue
        if tokens[0] == "v":
            if len(tokens) < 4:
                raise FormatError(
                    f"line {number}: vertex needs 3 coordinates, found {len(tokens) - 1}"
                )
            vertex_rows.append(tokens[1:4])
            vertex_numbers.append(number)
            continue
        if tokens[0] == "vt":
            uv_rows.append((tokens[1:3] + ["0"])[:2])
            uv_numbers.append(number)
            continue
        if tokens[0] == "usemtl":
            material = " ".join(tokens[1:])
            continue
        if tokens[0] == "mtllib":
            libraries.append(" ".join(tokens[1:]))
            continue
        if tokens[0] != "f":
            continue
        try:
            for token in tokens[1:]:
                vertex, _, rest = token.partition("/")
                face_indices.append(int(vertex))
                texture = rest.partition("/")[0]
                face_uv.append(int(texture) if texture else 0)
        except ValueError as err:
            raise FormatError(f"line {number}: cannot read face {line.strip()[:60]!r}") from err
        face_sizes.append(len(tokens) - 1)
        face_numbers.append(number)
        face_materials.append(material)
        n_defined.append(len(vertex_rows))
        uv_defined.append(len(uv_rows))
    vertices = parse_floats(vertex_rows, vertex_numbers, 3, "vertex coordinates")
    sizes = np.array(face_sizes, dtype=np.int64)
    flat = _resolve_indices(
        np.array(face_indices, dtype=np.int64),
        sizes,
        np.repeat(np.array(n_defined, dtype=np.int64), sizes),
        face_numbers,
        len(vertices),
    )
    reading = Reading(vertices, (flat, sizes))
    raw_uv = np.array(face_uv, dtype=np.int64)
    if uv_rows and raw_uv.any():
        uv = parse_floats(uv_rows, uv_numbers, 2, "texture coordinates")
        has_uv = raw_uv != 0
        index = _resolve_indices(
            np.where(has_uv, raw_uv, 1), sizes,
            np.repeat(np.array(uv_defined, dtype=np.int64), sizes), face_numbers, len(uv),
            what="texture coordinate",
        )
        corner_uv = np.where(has_uv[:, None], uv[index], np.nan)
        reading = reading._replace(corner_uv=corner_uv)
    if folder is not None and libraries and face_materials:
        reading = _with_materials(reading, folder, libraries, face_materials)
    return reading


class _Material(NamedTuple):
    color: NDArray[np.float64]  # (4,) RGBA in 0..1
    texture: str | None  # the map_Kd file, relative to the library's folder


def _read_library(path: Path) -> dict[str, _Material]:
    """The materials of one MTL file: ``Kd`` (default white), ``d`` (alpha) and ``map_Kd``."""
    materials: dict[str, _Material] = {}
    name = None
    for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
        tokens = line.partition("#")[0].split()
        if not tokens:
            continue
        if tokens[0] == "newmtl":
            name = " ".join(tokens[1:])
            materials[name] = _Material(np.ones(4), None)
        elif name is None:
            continue
        elif tokens[0] == "Kd" and len(tokens) >= 4:
            color = materials[name].color.copy()
            color[:3] = np.clip([float(value) for value in tokens[1:4]], 0.0, 1.0)
            materials[name] = materials[name]._replace(color=color)
        elif tokens[0] == "d" and len(tokens) >= 2:
            color = materials[name].color.copy()
            color[3] = min(max(float(tokens[1]), 0.0), 1.0)
            materials[name] = materials[name]._replace(color=color)
        elif tokens[0] == "map_Kd" and len(tokens) >= 2:
            materials[name] = materials[name]._replace(texture=tokens[-1])
    return materials


def _with_materials(reading: Reading, folder: Path, libraries: list[str],
                    face_materials: list[str]) -> Reading:
    """``reading`` with the colours and texture of the materials its faces use."""
    materials: dict[str, _Material] = {}
    for library in libraries:
        path = folder / library
        try:
            materials.update(_read_library(path))
        except (OSError, ValueError) as err:
            _log.warning("%s: material library %s cannot be read (%s); its colours are skipped",
                         file_label.get(), library, one_line(err))
    used = [name for name in dict.fromkeys(face_materials) if name in materials]
    if not used:
        return reading
    if len(used) == 1:
        reading = reading._replace(base_color=materials[used[0]].color)
    else:
        white = _Material(np.ones(4), None)
        colors = np.array([materials.get(name, white).color for name in face_materials])
        reading = reading._replace(polygon_colors=np.rint(colors * 255).astype(np.uint8))
    textured = [name for name in used if materials[name].texture is not None]
    if not textured or reading.corner_uv is None:
        return reading
    if len(textured) > 1:
        _log.warning("%s: %d textured materials; only the texture of %r is kept",
                     file_label.get(), len(textured), textured[0])
    image = folder / str(materials[textured[0]].texture)
    on_texture = np.repeat(np.array(face_materials) == textured[0], reading.polygons[1])
    corner_uv = np.where(on_texture[:, None], reading.corner_uv, np.nan)
    return reading._replace(corner_uv=corner_uv, texture=lambda: read_image(image))


def obj_bytes(vertices: NDArray[np.float64], faces: NDArray[np.int64], *, name: str) -> bytes:
    """Return OBJ text for ``(n_vertices, 3) float64`` vertices and ``(n_faces, 3) int64`` faces.

    A first comment line names the mesh ``name`` and its counts. Each float is
    written as its shortest exact repr, so the file reads back exactly.
    """
    lines = [f"# {name}: {len(vertices)} vertices, {len(faces)} faces\n"]
    lines.extend(f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist())
    lines.extend(f"f {a} {b} {c}\n" for a, b, c in (faces + 1).tolist())
    return "".join(lines).encode("ascii")


def _resolve_indices(
    raw: NDArray[np.int64],
    sizes: NDArray[np.int64],
    defined: NDArray[np.int64],
    face_numbers: list[int],
    n_vertices: int,
    what: str = "face",
) -> NDArray[np.int64]:
    """Turn OBJ face indices into 0-based ones, or raise on the first bad index.

    ``raw`` holds the file's indices (1-based, or negative counting back from
    ``defined``, the number of vertices (or texture coordinates, ``what``)
    defined before each index's face).
    """
    flat = np.where(raw > 0, raw - 1, defined + raw)
    is_bad = (raw == 0) | (flat < 0) | (flat >= n_vertices)
    if not is_bad.any():
        return flat
    first = int(np.argmax(is_bad))
    number, value = face_numbers[polygon_of(sizes, first)], int(raw[first])
    items = ("vertex", "vertices") if what == "face" else (what, what + "s")
    if value == 0:
        raise FormatError(f"line {number}: {what} index 0 is invalid (OBJ indices start at 1)")
    if value < 0:
        raise FormatError(
            f"line {number}: relative {what} index {value} reaches before the first {items[0]} "
            f"({plural(int(defined[first]), *items)} defined so far)"
        )
    raise FormatError(
        f"line {number}: {what} index {value} out of range, file has "
        f"{plural(n_vertices, *items)}"
    )
