"""The model's up axis: the one its file format fixes, or the side it stands on.

Pictures and searches that should keep a model upright (``vptool render``,
``best-view`` and ``thumbnails`` with ``--up``, ``SearchSettings(up=...)``)
take the up axis as a direction, or ``"auto"`` for a mixed folder, decided
per model by :func:`auto_up`:

1. **The file's convention.** glTF (``.gltf``, ``.glb``) is +y up by its
   specification: ``(0, 1, 0)``.
2. **The resting rule**, for formats that fix no axis (PLY, OBJ, STL, OFF,
   ...): the up axis is +y or +z, the two conventions models are made in,
   whichever the model stands on more broadly. For an axis ``u`` the
   *footprint* is the area of the convex hull, in the plane across ``u``, of
   the vertices within :data:`CONTACT_SHARE` of the model's extent of its
   lowest point along ``u`` (the points it would touch a floor with, its
   support polygon). +z wins when its footprint is larger than that of +y by
   more than a millionth; otherwise (ties and flat-bottomed blocks) +y.

The rule picks the upright pose of most real models: a z-up vehicle stands
on its four wheels (the hull of their contacts), a y-up bunny or chair on its
feet. A flat model (a sign, a door, a wall panel) stands more broadly on its
face than on its edge and comes out lying down: give its axis with ``--up``.
Only +y and +z are candidates: a model made upside down or x-up is not
guessed.
"""

from __future__ import annotations

from pathlib import Path
from typing import Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.mesh import Mesh
from vptoolkit.point_cloud import PointCloud

__all__ = ["CONTACT_SHARE", "FORMAT_UP", "auto_up", "footprint_area", "resting_up",
           "rotation_between"]

CONTACT_SHARE: Final = 0.01
"""Vertices within this share of the extent along an axis of the lowest one touch the floor."""

FORMAT_UP: Final = {".gltf": (0.0, 1.0, 0.0), ".glb": (0.0, 1.0, 0.0)}
"""Up axis of the file formats whose specification fixes one (glTF: +y)."""

_CANDIDATES: Final = ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def footprint_area(vertices: NDArray[np.float64], up: tuple[float, float, float]) -> float:
    """Area of the support polygon of ``vertices`` ``(n, 3)`` standing on a floor across ``up``.

    The support polygon is the 2-D convex hull (Andrew's monotone chain) of
    the vertices within :data:`CONTACT_SHARE` of the extent along the unit
    axis ``up`` of the lowest, projected onto the plane across ``up``; its
    area is in squared model units (0 for fewer than three contact points or
    points on a line).
    """
    axis = np.asarray(up, dtype=np.float64)
    heights = vertices @ axis
    low, extent = float(heights.min()), float(np.ptp(heights))
    contact = vertices[heights <= low + CONTACT_SHARE * extent]
    first = np.cross(axis, np.eye(3)[int(np.argmin(np.abs(axis)))])
    first /= np.linalg.norm(first)
    flat = np.unique(np.column_stack([contact @ first, contact @ np.cross(axis, first)]), axis=0)
    if len(flat) < 3:
        return 0.0
    return _hull_area(flat)


def _hull_area(points: NDArray[np.float64]) -> float:
    """Area of the convex hull of distinct 2-D points ``(n, 2)`` sorted by x then y."""
    def chain(ordered: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        kept: list[NDArray[np.float64]] = []
        for point in ordered:
            while len(kept) >= 2 and _turn(kept[-2], kept[-1], point) <= 0.0:
                kept.pop()
            kept.append(point)
        return kept[:-1]

    hull = np.array(chain(points) + chain(points[::-1]))
    x, y = hull[:, 0], hull[:, 1]
    return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _turn(a: NDArray[np.float64], b: NDArray[np.float64], c: NDArray[np.float64]) -> float:
    """Twice the signed area of triangle ``abc`` (> 0 for a left turn)."""
    return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


def resting_up(model: Mesh | PointCloud) -> tuple[float, float, float]:
    """The resting rule (module docstring): ``(0, 0, 1)`` if the model (a mesh's vertices, a
    cloud's points) stands more broadly on its -z side than on its -y side, else ``(0, 1, 0)``."""
    vertices = model.vertices if isinstance(model, Mesh) else model.points
    y_up, z_up = (footprint_area(vertices, axis) for axis in _CANDIDATES)
    return _CANDIDATES[1] if z_up > y_up * (1.0 + 1e-6) else _CANDIDATES[0]


def auto_up(mesh: Mesh | PointCloud,
            path: str | Path | None = None) -> tuple[float, float, float]:
    """The up axis of a model: its file format's (:data:`FORMAT_UP`) where ``path`` names one,
    else :func:`resting_up`."""
    if path is not None:
        fixed = FORMAT_UP.get(Path(path).suffix.lower())
        if fixed is not None:
            return fixed
    return resting_up(mesh)


def rotation_between(source: tuple[float, float, float],
                     target: tuple[float, float, float]) -> NDArray[np.float64]:
    """The rotation ``(3, 3) float64`` of least angle that turns the unit direction ``source``
    into the unit direction ``target`` (Rodrigues' formula; opposite directions: half a turn
    about an axis across them), e.g. a z-up model's +z to a picture's +y."""
    a = np.asarray(source, dtype=np.float64)
    b = np.asarray(target, dtype=np.float64)
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    axis = np.cross(a, b)
    sine, cosine = float(np.linalg.norm(axis)), float(a @ b)
    if sine < 1e-12:
        if cosine > 0.0:
            return np.eye(3)
        axis = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    axis /= sine
    cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                      [-axis[1], axis[0], 0.0]])
    return np.eye(3) + sine * cross + (1.0 - cosine) * cross @ cross
