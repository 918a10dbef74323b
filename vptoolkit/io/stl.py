"""Read and write STL triangle soup, binary or ASCII."""

from __future__ import annotations

import re
import struct

import numpy as np
from numpy.typing import NDArray

from vptoolkit.io._polygons import FormatError, Reading, first_non_float_row, triangle_polygons

__all__ = ["read_stl", "stl_bytes"]

_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
_VERTEX = re.compile(rb"(?i)\bvertex[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)")


def read_stl(data: bytes) -> Reading:
    """Read binary or ASCII STL as triangle soup (three vertices per face).

    A file whose length matches its binary triangle count is binary, even if
    its 80-byte header starts with ``solid`` (as some CAD exporters write).

    Parameters
    ----------
    data : bytes
        The whole file; its length tells binary from ASCII.

    Returns
    -------
    Reading
        ``vertices (3 * n_faces, 3) float64``, the corners of each triangle in
        turn (shared vertices are not merged), and the polygons: triangle
        ``k`` is vertices ``3k, 3k + 1, 3k + 2``. STL has no colours.

    Raises
    ------
    FormatError
        If the length disagrees with the binary triangle count and the file
        is not ASCII STL, or an ASCII vertex cannot be read.
    """
    n_declared = int.from_bytes(data[80:84], "little") if len(data) >= 84 else -1
    if n_declared >= 0 and len(data) == 84 + 50 * n_declared:
        records = np.frombuffer(data, dtype=_RECORD, count=n_declared, offset=84)
        vertices = records["corners"].reshape(-1, 3).astype(np.float64)
    elif data.lstrip()[:5].lower() == b"solid" and b"\0" not in data:
        vertices = _read_ascii(data)
    elif n_declared < 0:
        raise FormatError(f"not an STL file (binary STL needs 84+ bytes, file has {len(data)})")
    else:
        raise FormatError(
            f"binary STL header declares {n_declared} triangles ({84 + 50 * n_declared} bytes), "
            f"file has {len(data)} bytes"
        )
    n_faces = len(vertices) // 3
    return Reading(vertices,
                   triangle_polygons(np.arange(3 * n_faces, dtype=np.int64).reshape(-1, 3)))


def stl_bytes(vertices: NDArray[np.float64], faces: NDArray[np.int64], *, name: str) -> bytes:
    """Return binary STL of ``(n_vertices, 3) float64`` vertices and ``(n_faces, 3) int64`` faces.

    Coordinates are rounded to float32 and shared vertices are not stored.
    Each record carries the unit normal of its triangle (zero if degenerate),
    and the 80-byte header names the mesh ``name``.
    """
    corners = vertices[faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0)
    records = np.zeros(len(faces), dtype=_RECORD)
    records["normal"] = normals
    records["corners"] = corners
    header = f"vptoolkit binary STL: {name}".encode("utf-8", errors="replace")[:80]
    return header.ljust(80, b" ") + struct.pack("<I", len(faces)) + records.tobytes()


def _read_ascii(data: bytes) -> NDArray[np.float64]:
    """Return the ``vertex x y z`` lines of ASCII STL as ``(n, 3) float64``."""
    matches = _VERTEX.findall(data)
    if len(matches) % 3:
        raise FormatError(f"ASCII STL has {len(matches)} vertex lines, not a multiple of 3")
    if not matches:
        return np.zeros((0, 3), dtype=np.float64)
    rows = [[token.decode("latin-1") for token in match] for match in matches]
    try:
        return np.array(rows, dtype=np.float64)
    except ValueError as err:
        k = first_non_float_row(rows)
        if k is None:
            raise
        raise FormatError(f"cannot read STL vertex {' '.join(rows[k])[:60]!r}") from err
