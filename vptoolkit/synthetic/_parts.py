"""Closed primitive surfaces of the synthetic shapes, their transforms and assembly.

A part is a closed triangle surface, ``(n, 3) float64`` vertices and
``(m, 3) int64`` faces, outward and counter-clockwise. The names keep their
underscores: they are the private building blocks of
:mod:`vptoolkit.synthetic._categories`, not a public mesh API.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.mesh import Mesh

# A part is a closed triangle surface: (n, 3) float64 vertices, (m, 3) int64 faces.
_Part = tuple[NDArray[np.float64], NDArray[np.int64]]

_SEGMENTS = 24
"""Default number of segments around a surface of revolution (even: mirror symmetric)."""


# ============================================================================ primitives
#
# Each primitive returns a closed surface with outward counter-clockwise faces.
# Transforms use proper rotations and positive scales only (they keep the
# winding); _mirrored reflects across y = 0 and reverses the winding.

# Faces of a block with corners numbered like the unit cube's, see _block.
_BLOCK_FACES = np.array(
    [
        [0, 3, 2], [0, 2, 1],  # bottom (-z)
        [4, 5, 6], [4, 6, 7],  # top (+z)
        [0, 1, 5], [0, 5, 4],  # -y
        [1, 2, 6], [1, 6, 5],  # +x
        [2, 3, 7], [2, 7, 6],  # +y
        [3, 0, 4], [3, 4, 7],  # -x
    ],
    dtype=np.int64,
)


def _block(corners: ArrayLike) -> _Part:
    """A hexahedron (12 triangles) from 8 corners.

    Parameters
    ----------
    corners : (8, 3) float
        Numbered like the unit cube's ``(x, y, z)`` corners: bottom ``(0,0,0),
        (1,0,0), (1,1,0), (0,1,0)``, then the top in the same order. Any
        non-inverted deformation of that cube (tapered wing, slanted panel)
        gives outward faces.
    """
    return np.asarray(corners, dtype=np.float64).reshape(8, 3), _BLOCK_FACES.copy()


def _box(low: ArrayLike, high: ArrayLike) -> _Part:
    """An axis-aligned box between the corners ``low`` and ``high``, each (3,) float."""
    x0, y0, z0 = np.asarray(low, dtype=np.float64)
    x1, y1, z1 = np.asarray(high, dtype=np.float64)
    return _block([
        [x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
        [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1],
    ])


def _centred_box(centre: ArrayLike, size: ArrayLike) -> _Part:
    """An axis-aligned box of ``size`` (3,) around ``centre`` (3,)."""
    middle = np.asarray(centre, dtype=np.float64)
    half = np.asarray(size, dtype=np.float64) / 2.0
    return _box(middle - half, middle + half)


def _revolve(
    profile: ArrayLike, *, n_segments: int = _SEGMENTS, is_loop: bool = False
) -> _Part:
    """A surface of revolution about the ``z`` axis.

    Parameters
    ----------
    profile : (n_points, 2) float
        ``(radius, z)`` points. An open profile runs from bottom to top with
        the solid on the side of the axis; an end with radius 0 becomes a
        pole and an end with radius > 0 is closed by a flat cap. A loop
        (``is_loop``) runs counter-clockwise in the ``(radius, z)`` plane with
        all radii > 0 (a torus). Consecutive points must differ.
    n_segments : int
        Points per ring, even so that the surface is mirror symmetric across
        ``y = 0`` (ring angles ``2 pi j / n_segments``, starting on ``+x``).
    is_loop : bool
        Whether the profile is closed (default: False).
    """
    points = np.asarray(profile, dtype=np.float64)
    if not is_loop:
        if points[0, 0] > 0:
            points = np.vstack([[0.0, points[0, 1]], points])
        if points[-1, 0] > 0:
            points = np.vstack([points, [0.0, points[-1, 1]]])
        rings = points[1:-1]
    else:
        rings = points
    angles = 2.0 * np.pi * np.arange(n_segments) / n_segments
    n_rings = len(rings)
    ring_xyz = np.stack([
        np.outer(rings[:, 0], np.cos(angles)),
        np.outer(rings[:, 0], np.sin(angles)),
        np.repeat(rings[:, 1:2], n_segments, axis=1),
    ], axis=-1).reshape(-1, 3)

    j = np.arange(n_segments)
    j_next = (j + 1) % n_segments
    faces: list[NDArray[np.int64]] = []
    offset = 0 if is_loop else 1  # the bottom pole is vertex 0
    ring_pairs = [(i, (i + 1) % n_rings) for i in range(n_rings if is_loop else n_rings - 1)]
    for lower, upper in ring_pairs:
        a = offset + lower * n_segments + j
        b = offset + lower * n_segments + j_next
        c = offset + upper * n_segments + j_next
        d = offset + upper * n_segments + j
        faces += [np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)]
    if is_loop:
        return ring_xyz, np.concatenate(faces).astype(np.int64)

    top = 1 + n_rings * n_segments
    first, last = 1 + j, 1 + (n_rings - 1) * n_segments + j
    first_next, last_next = 1 + j_next, 1 + (n_rings - 1) * n_segments + j_next
    faces.append(np.stack([np.zeros_like(j), first_next, first], axis=1))
    faces.append(np.stack([last, last_next, np.full_like(j, top)], axis=1))
    vertices = np.vstack([[0.0, 0.0, points[0, 1]], ring_xyz, [0.0, 0.0, points[-1, 1]]])
    return vertices, np.concatenate(faces).astype(np.int64)


def _cylinder(radius: float, z0: float, z1: float, *, n_segments: int = _SEGMENTS) -> _Part:
    """A capped cylinder along ``z`` from ``z0`` to ``z1`` (``z0 < z1``)."""
    return _revolve([[radius, z0], [radius, z1]], n_segments=n_segments)


def _frustum(
    r0: float, r1: float, z0: float, z1: float, *, n_segments: int = _SEGMENTS
) -> _Part:
    """A capped cone frustum along ``z``: radius ``r0`` at ``z0``, ``r1`` at ``z1``."""
    return _revolve([[r0, z0], [r1, z1]], n_segments=n_segments)


def _sphere(radius: float, *, n_segments: int = 16) -> _Part:
    """A UV sphere about the origin with ``n_segments // 2`` bands from pole to pole."""
    theta = np.linspace(-np.pi / 2, np.pi / 2, n_segments // 2 + 1)
    profile = np.stack([radius * np.cos(theta), radius * np.sin(theta)], axis=1)
    profile[[0, -1], 0] = 0.0  # exact poles
    return _revolve(profile, n_segments=n_segments)


def _torus(major: float, minor: float, *, n_major: int = _SEGMENTS, n_minor: int = 10) -> _Part:
    """A torus about the ``z`` axis, centred at the origin (``major > minor``)."""
    phi = 2.0 * np.pi * np.arange(n_minor) / n_minor
    loop = np.stack([major + minor * np.cos(phi), minor * np.sin(phi)], axis=1)
    return _revolve(loop, n_segments=n_major, is_loop=True)


def _rotation(axis: str, angle: float) -> NDArray[np.float64]:
    """Right-handed rotation (3, 3) by ``angle`` radians about ``"x"``, ``"y"`` or ``"z"``."""
    c, s = math.cos(angle), math.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=np.float64)
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], dtype=np.float64)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=np.float64)


# Rotations taking a primitive built along z onto the other axes.
_Z_TO_X = _rotation("y", np.pi / 2)
_Z_TO_Y = _rotation("x", -np.pi / 2)


def _moved(
    part: _Part,
    *,
    scale: ArrayLike = 1.0,
    rotation: NDArray[np.float64] | None = None,
    offset: ArrayLike = 0.0,
) -> _Part:
    """Scale (positive, per axis), then rotate (proper), then translate a part."""
    vertices, faces = part
    vertices = vertices * np.asarray(scale, dtype=np.float64)
    if rotation is not None:
        vertices = vertices @ rotation.T
    return vertices + np.asarray(offset, dtype=np.float64), faces


def _mirrored(part: _Part) -> _Part:
    """The reflection of a part across ``y = 0``, with the winding reversed to stay outward."""
    vertices, faces = part
    return vertices * np.array([1.0, -1.0, 1.0]), faces[:, ::-1].copy()


def _pair(part: _Part) -> list[_Part]:
    """A part and its mirror image across ``y = 0``."""
    return [part, _mirrored(part)]


def _rod(start: ArrayLike, end: ArrayLike, radius: float, *, n_segments: int = 12) -> _Part:
    """A capped cylinder from ``start`` to ``end`` (each (3,) float)."""
    start, end = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    axis = end - start
    length = float(np.linalg.norm(axis))
    return _moved(_cylinder(radius, 0.0, length, n_segments=n_segments),
                  rotation=_align_z(axis / length), offset=start)


def _align_z(direction: NDArray[np.float64]) -> NDArray[np.float64]:
    """The rotation (3, 3) about ``z x direction`` taking ``+z`` onto the unit ``direction``."""
    cross = np.cross([0.0, 0.0, 1.0], direction)
    sin, cos = float(np.linalg.norm(cross)), float(direction[2])
    if sin < 1e-12:
        return np.eye(3) if cos > 0 else _rotation("x", np.pi)
    k = cross / sin
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + sin * skew + (1.0 - cos) * skew @ skew


def _assemble(parts: Iterable[_Part], *, name: str) -> Mesh:
    """Concatenate parts into one Mesh with its bounding box centred at the origin."""
    vertex_blocks: list[NDArray[np.float64]] = []
    face_blocks: list[NDArray[np.int64]] = []
    n_vertices = 0
    for vertices, faces in parts:
        vertex_blocks.append(vertices)
        face_blocks.append(faces + n_vertices)
        n_vertices += len(vertices)
    vertices = np.vstack(vertex_blocks)
    vertices = vertices - (vertices.min(axis=0) + vertices.max(axis=0)) / 2.0
    return Mesh(vertices, np.vstack(face_blocks).astype(np.int64), name)


def _pick(rng: np.random.Generator, options: Sequence[str], weights: Sequence[float]) -> str:
    """One of ``options`` drawn with probabilities ``weights`` (summing to 1)."""
    return options[int(rng.choice(len(options), p=weights))]
