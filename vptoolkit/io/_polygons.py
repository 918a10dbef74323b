"""Helpers shared by the format readers: polygon lists, number parsing, errors.

A reader returns a :class:`Reading`: ``(n_vertices, 3) float64`` coordinates,
a :data:`Polygons` pair and what else the file holds (normals, colours,
texture coordinates). :func:`check_and_triangulate` then validates the
geometry and fan-triangulates the polygons for every format alike, and
:func:`triangle_rows` carries per-polygon and per-corner values onto the
triangles the same way.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import NamedTuple, TypeVar

import numpy as np
from numpy.typing import NDArray

Polygons = tuple[NDArray[np.int64], NDArray[np.int64]]
"""Polygon faces as ``(flat_indices, sizes)``: ``(sum(sizes),) int64`` vertex
indices of every polygon in file order, and ``(n_polygons,) int64`` vertex
counts per polygon."""


_Item = TypeVar("_Item", bound=np.generic)


class FormatError(Exception):
    """A reader's complaint about the file content; :func:`vptoolkit.io.load` prefixes the name."""


class Reading(NamedTuple):
    """What a reader found in one file; every field after ``polygons`` is None when absent.

    Attributes
    ----------
    vertices : (n_vertices, 3) float64
        Coordinates in file order.
    polygons : Polygons
        The faces; empty for a file of points.
    normals : (n_vertices, 3) float64 or None
        Per-vertex normals as stored (not yet unit length).
    vertex_colors : (n_vertices, 4) uint8 or None
        RGBA per vertex (:func:`rgba`).
    polygon_colors : (n_polygons, 4) uint8 or None
        RGBA per polygon.
    vertex_uv : (n_vertices, 2) float64 or None
        Texture coordinates per vertex, ``(0, 0)`` bottom-left.
    corner_uv : (len(flat_indices), 2) float64 or None
        Texture coordinates per polygon corner (OBJ's ``v/vt``), NaN where a
        corner has none.
    base_color : (4,) float64 or None
        The one material colour, RGBA in 0..1.
    texture : callable or None
        Returns the base-colour image as ``(height, width, 4) uint8``; called
        only when the appearance is asked for, so that reading geometry never
        decodes images.
    """

    vertices: NDArray[np.float64]
    polygons: Polygons
    normals: NDArray[np.float64] | None = None
    vertex_colors: NDArray[np.uint8] | None = None
    polygon_colors: NDArray[np.uint8] | None = None
    vertex_uv: NDArray[np.float64] | None = None
    corner_uv: NDArray[np.float64] | None = None
    base_color: NDArray[np.float64] | None = None
    texture: Callable[[], NDArray[np.uint8]] | None = None


def rgba(channels: NDArray[np.float64], *, is_float: bool, what: str) -> NDArray[np.uint8]:
    """Colours as ``(n, 4) uint8``: 0..1 floats scaled by 255, integers 0..255 as they are.

    Parameters
    ----------
    channels : (n, 3) or (n, 4) float64
        Red, green, blue and maybe alpha (255 or 1.0 when absent).
    is_float : bool
        Whether the file stores them as floats in 0..1.
    what : str
        ``"vertex colours"`` or ``"face colours"``, for the message.

    Raises
    ------
    FormatError
        If a value is NaN or outside 0..1 (floats) or 0..255 (integers).
    """
    top = 1.0 if is_float else 255.0
    if not (np.isfinite(channels).all() and (channels >= 0).all() and (channels <= top).all()):
        found = ("NaN" if not np.isfinite(channels).all()
                 else f"{channels.min():.4g}..{channels.max():.4g}")
        raise FormatError(f"{what} outside 0..{top:g} (found {found})")
    scaled = np.rint(channels * (255.0 / top)).astype(np.uint8)
    if scaled.shape[1] == 4:
        return scaled
    return np.concatenate([scaled, np.full((len(scaled), 1), 255, np.uint8)], axis=1)


def triangle_rows(values: NDArray[_Item], sizes: NDArray[np.int64], *,
                  per_corner: bool) -> NDArray[_Item]:
    """Carry per-polygon (or per-corner) values onto the fan triangles of :func:`fan_triangulate`.

    Parameters
    ----------
    values : (n_polygons, ...) or (sum(sizes), ...) array
        One row per polygon, or with ``per_corner`` one per polygon corner.
    sizes : (n_polygons,) int64
        The polygons' vertex counts.
    per_corner : bool
        Whether ``values`` has a row per corner.

    Returns
    -------
    (n_triangles, ...) or (n_triangles, 3, ...) array
        A polygon's row repeated for each of its triangles, or each triangle's
        three corners' rows.
    """
    if per_corner:
        return values[fan_triangulate(np.arange(len(values), dtype=np.int64), sizes)]
    return np.repeat(values, np.maximum(sizes - 2, 0), axis=0)


def plural(count: int, one: str, many: str) -> str:
    """Return ``"1 vertex"`` or ``"3 vertices"``: the count, then ``one`` or ``many``."""
    return f"{count} {one if count == 1 else many}"


def triangle_polygons(triangles: NDArray[np.int64]) -> Polygons:
    """Return ``(n_faces, 3) int64`` triangles as a :data:`Polygons` pair."""
    return triangles.reshape(-1), np.full(len(triangles), 3, dtype=np.int64)


def polygon_of(sizes: NDArray[np.int64], position: int) -> int:
    """Return the polygon that holds entry ``position`` of the flat index array."""
    return int(np.searchsorted(np.cumsum(sizes), position, side="right"))


def check_and_triangulate(vertices: NDArray[np.float64], polygons: Polygons) -> NDArray[np.int64]:
    """Validate vertices and (at least one) polygons; return ``(n_faces, 3) int64`` triangles."""
    flat, sizes = polygons
    n_vertices = len(vertices)
    if n_vertices == 0 and len(sizes) == 0:
        raise FormatError("no geometry (no vertices, no faces)")
    is_finite = np.isfinite(vertices).all(axis=1)
    if not is_finite.all():
        first = int(np.argmin(is_finite))
        n_bad = int((~is_finite).sum())
        raise FormatError(
            f"{plural(n_bad, 'vertex has', 'vertices have')} NaN or infinite coordinates "
            f"(first: vertex {first})"
        )
    is_bad = (flat < 0) | (flat >= n_vertices)
    if is_bad.any():
        first = int(np.argmax(is_bad))
        raise FormatError(
            f"face {polygon_of(sizes, first)} refers to vertex {int(flat[first])}, "
            f"file has {n_vertices} vertices"
        )
    faces = fan_triangulate(flat, sizes)
    if len(faces) == 0:
        shorter = plural(len(sizes), "shorter one", "shorter ones")
        raise FormatError(f"no faces with 3 or more vertices, only {shorter}")
    return faces


def fan_triangulate(flat: NDArray[np.int64], sizes: NDArray[np.int64]) -> NDArray[np.int64]:
    """Fan-triangulate polygons; those with fewer than 3 vertices are dropped.

    ``(a, b, c, d)`` becomes ``(a, b, c)`` and ``(a, c, d)``. Returns
    ``(sum(max(sizes - 2, 0)), 3) int64``, the triangles of each polygon
    contiguous and in file order.
    """
    if len(sizes) and (sizes == 3).all():
        return flat.reshape(-1, 3)
    starts = np.cumsum(sizes) - sizes
    n_triangles = np.maximum(sizes - 2, 0)
    polygon = np.repeat(np.arange(len(sizes)), n_triangles)
    first_triangle = np.cumsum(n_triangles) - n_triangles
    corner = np.arange(int(n_triangles.sum())) - first_triangle[polygon]
    base = starts[polygon]
    return np.stack([flat[base], flat[base + corner + 1], flat[base + corner + 2]], axis=1)


def first_non_float_row(rows: list[list[str]]) -> int | None:
    """Return the index of the first row with a token ``float()`` rejects, or None."""
    for k, row in enumerate(rows):
        try:
            [float(token) for token in row]
        except ValueError:
            return k
    return None


def parse_floats(
    rows: list[list[str]], line_numbers: list[int], n_columns: int, what: str
) -> NDArray[np.float64]:
    """Convert rows of ``n_columns`` number strings to ``(n_rows, n_columns) float64``.

    A bad number raises ``line N: cannot read <what> '<row>'``.
    """
    if not rows:
        return np.zeros((0, n_columns), dtype=np.float64)
    try:
        return np.array(rows, dtype=np.float64).reshape(len(rows), n_columns)
    except ValueError as err:
        k = first_non_float_row(rows)
        if k is None:
            raise
        raise FormatError(
            f"line {line_numbers[k]}: cannot read {what} {' '.join(rows[k])!r}"
        ) from err


def parse_counted_polygons(
    rows: list[list[str]], line_numbers: list[int], *, lead: int, is_exact: bool, min_size: int
) -> Polygons:
    """Parse rows holding ``count i_1 ... i_count`` after ``lead`` other values.

    With ``is_exact`` the row must end after the indices (PLY without further
    properties); otherwise trailing values such as OFF face colours are ignored.
    A count below ``min_size`` is an error.
    """
    sizes = np.zeros(len(rows), dtype=np.int64)
    index_tokens: list[str] = []
    for k, row in enumerate(rows):
        try:
            size = int(row[lead])
        except (ValueError, IndexError) as err:
            found = repr(row[lead]) if len(row) > lead else "nothing"
            raise FormatError(
                f"line {line_numbers[k]}: expected the face's vertex count, found {found}"
            ) from err
        n_listed = len(row) - lead - 1
        if size < min_size:
            raise FormatError(
                f"line {line_numbers[k]}: face has {size} vertices, need at least {min_size}"
            )
        if size < 0 or n_listed < size or (is_exact and n_listed != size):
            raise FormatError(
                f"line {line_numbers[k]}: face declares {size} vertices but lists {n_listed} values"
            )
        sizes[k] = size
        index_tokens.extend(row[lead + 1 : lead + 1 + size])
    try:
        flat = np.array(index_tokens, dtype=np.int64)
    except ValueError as err:
        for k, row in enumerate(rows):
            for token in row[lead + 1 : lead + 1 + int(sizes[k])]:
                if not re.fullmatch(r"[+-]?\d+", token):
                    raise FormatError(
                        f"line {line_numbers[k]}: face index {token!r} is not an integer"
                    ) from err
        raise
    return flat, sizes
