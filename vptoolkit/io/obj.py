"""Read and write the vertices and faces of Wavefront OBJ files."""

from __future__ import annotations

import re

import numpy as np
from numpy.typing import NDArray

from vptoolkit.io._polygons import FormatError, Polygons, parse_floats, plural, polygon_of

__all__ = ["obj_bytes", "read_obj"]


def read_obj(data: bytes) -> tuple[NDArray[np.float64], Polygons]:
    """Read the ``v`` and ``f`` statements of a Wavefront OBJ file.

    Indices are 1-based; negative ones count back from the last vertex defined
    so far. Only the vertex part of ``v/vt/vn`` is used; materials, texture
    coordinates, normals, lines and points are ignored. A backslash at the end
    of a line continues it, and ``#`` starts a comment.

    Parameters
    ----------
    data : bytes
        The whole file, UTF-8 (undecodable bytes are replaced).

    Returns
    -------
    vertices : (n_vertices, 3) float64
        Coordinates in file order, without merging or splitting.
    polygons : Polygons
        ``(flat_indices, sizes)`` of the faces in file order, indices 0-based.

    Raises
    ------
    FormatError
        If a vertex or face cannot be read or a face index is out of range.
    """
    text = data.decode("utf-8", errors="replace")
    if "\\" in text:  # line continuation
        text = re.sub(r"\\[ \t]*\r?\n", " ", text)
    vertex_rows: list[list[str]] = []
    vertex_numbers: list[int] = []
    face_indices: list[int] = []
    face_sizes: list[int] = []
    face_numbers: list[int] = []
    n_defined: list[int] = []  # vertices defined before each face
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.lstrip()
        if line[:2] not in ("v ", "v\t", "f ", "f\t"):
            continue
        tokens = line.partition("#")[0].split()
        if tokens[0] == "v":
            if len(tokens) < 4:
                raise FormatError(
                    f"line {number}: vertex needs 3 coordinates, found {len(tokens) - 1}"
                )
            vertex_rows.append(tokens[1:4])
            vertex_numbers.append(number)
            continue
        try:
            face_indices.extend(int(token.partition("/")[0]) for token in tokens[1:])
        except ValueError as err:
            raise FormatError(f"line {number}: cannot read face {line.strip()[:60]!r}") from err
        face_sizes.append(len(tokens) - 1)
        face_numbers.append(number)
        n_defined.append(len(vertex_rows))
    vertices = parse_floats(vertex_rows, vertex_numbers, 3, "vertex coordinates")
    sizes = np.array(face_sizes, dtype=np.int64)
    flat = _resolve_indices(
        np.array(face_indices, dtype=np.int64),
        sizes,
        np.repeat(np.array(n_defined, dtype=np.int64), sizes),
        face_numbers,
        len(vertices),
    )
    return vertices, (flat, sizes)


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
) -> NDArray[np.int64]:
    """Turn OBJ face indices into 0-based ones, or raise on the first bad index.

    ``raw`` holds the file's indices (1-based, or negative counting back from
    ``defined``, the number of vertices defined before each index's face).
    """
    flat = np.where(raw > 0, raw - 1, defined + raw)
    is_bad = (raw == 0) | (flat < 0) | (flat >= n_vertices)
    if not is_bad.any():
        return flat
    first = int(np.argmax(is_bad))
    number, value = face_numbers[polygon_of(sizes, first)], int(raw[first])
    if value == 0:
        raise FormatError(f"line {number}: face index 0 is invalid (OBJ indices start at 1)")
    if value < 0:
        raise FormatError(
            f"line {number}: relative face index {value} reaches before the first vertex "
            f"({plural(int(defined[first]), 'vertex', 'vertices')} defined so far)"
        )
    raise FormatError(
        f"line {number}: face index {value} out of range, file has "
        f"{plural(n_vertices, 'vertex', 'vertices')}"
    )
