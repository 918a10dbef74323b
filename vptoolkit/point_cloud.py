"""The point cloud container of vptoolkit: points without faces, with normals if known.

A :class:`PointCloud` is what :func:`vptoolkit.io.load` returns for a file or
object that holds points and no faces (a PLY without a face element, a
points-only format such as NPY, PCD or LAS, an Open3D or trimesh point
cloud); :func:`voxel_subset` thins a cloud too large to keep. Like
:class:`~vptoolkit.mesh.Mesh` it is checked once, when it is made, so every
function that receives one can trust its arrays. Colours are not geometry and
live apart, in :class:`vptoolkit.appearance.Appearance`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.errors import InputError
from vptoolkit.mesh import check_coordinate_range

__all__ = ["MAX_POINTS", "PointCloud", "voxel_subset"]

MAX_POINTS = 20_000_000
"""Most points a loaded cloud keeps by default (:func:`vptoolkit.io.load`'s ``max_points``).

20 million points are 480 MB of float64 coordinates, and about as much again
for normals; every use of a cloud here (the network's 4096 points, normals
for the unoccluded estimate) needs far fewer. A larger cloud is thinned by
:func:`voxel_subset`, with a warning.
"""


@dataclass(frozen=True, eq=False)
class PointCloud:
    """Points in space, with a unit normal per point if known.

    Parameters
    ----------
    points : (n_points, 3) float64
        Positions in model units.
    normals : (n_points, 3) float64 or None
        One normal per point, scaled to unit length here; None when the source
        has none (default: None).
    name : str
        A label for messages and outputs, usually the file stem (default: "points").

    Raises
    ------
    InputError
        The message starts with ``name``: the arrays have the wrong shape,
        there are no points, a coordinate is NaN or infinite or beyond the
        float32 range the rest of the toolkit keeps
        (:func:`vptoolkit.mesh.check_coordinate_range`, the rule meshes
        follow: any scale from 1e-37 to 1e38 is accepted), the points lie on
        one line (one point, all points equal, or collinear: no extent of a
        surface to look at), or a normal is NaN, infinite or of zero length.

    Notes
    -----
    "On one line" compares the second principal variance of the points with
    the first, after scaling the cloud to a unit box, so the rule does not
    depend on the cloud's scale: it holds when ``var_2 <= 1e-10 var_1``.
    """

    points: NDArray[np.float64]
    normals: NDArray[np.float64] | None = None
    name: str = field(default="points")

    def __post_init__(self) -> None:
        points = _as_rows(self.points, self.name, "points")
        if len(points) == 0:
            raise InputError(f"{self.name}: point cloud has no points")
        if not np.isfinite(points).all():
            n_bad = int((~np.isfinite(points).all(axis=1)).sum())
            raise InputError(f"{self.name}: {n_bad} points have NaN or infinite coordinates")
        check_coordinate_range(points, self.name, "point cloud")
        if _on_one_line(points):
            raise InputError(
                f"{self.name}: its {len(points)} point(s) lie on one line, without the extent of "
                "a surface; a view needs a shape (points not all on a line)"
            )
        points.setflags(write=False)
        object.__setattr__(self, "points", points)
        if self.normals is not None:
            normals = _as_rows(self.normals, self.name, "normals")
            if len(normals) != len(points):
                raise InputError(f"{self.name}: {len(normals)} normals for {len(points)} points")
            # the largest component first, so that the square neither overflows nor underflows
            largest = np.abs(normals).max(axis=1, keepdims=True) if len(normals) else normals
            if not np.isfinite(normals).all() or not largest.all():
                raise InputError(f"{self.name}: a normal is NaN, infinite or of zero length")
            scaled = normals / largest
            normals = scaled / np.linalg.norm(scaled, axis=1, keepdims=True)
            normals.setflags(write=False)
            object.__setattr__(self, "normals", normals)

    @property
    def n_points(self) -> int:
        """Number of points."""
        return int(self.points.shape[0])

    def __repr__(self) -> str:
        return (f"PointCloud(name={self.name!r}, n_points={self.n_points}, "
                f"normals={self.normals is not None})")


def voxel_subset(points: NDArray[np.float64], max_points: int) -> NDArray[np.int64]:
    """Indices of at most ``max_points`` points, one per cell of the finest fitting voxel grid.

    Cubic cells of side ``side * extent`` (``extent`` the largest side of the
    bounding box), ``side`` from the sequence ``max_points^(-1/3) * 1.25^k``
    (``k`` any integer, down to :data:`_FINEST_SIDE`): the smallest side of
    the sequence at which at most ``max_points`` cells hold points. The search
    starts at ``k = 0`` (as fine as a solid of ``max_points`` cells needs),
    grows the cells while too many are occupied and, where that first grid
    fits, shrinks them while they still fit, so a surface, which fills only a
    shell of a solid's cells, keeps between about ``max_points / 1.25^2`` and
    ``max_points`` points, not the far fewer of the first grid. Each occupied
    cell keeps its first point in input order. The result is deterministic
    and spreads the kept points evenly over the shape, unlike a random subset
    that keeps dense regions dense.

    Parameters
    ----------
    points : (n_points, 3) float64
        Finite coordinates.
    max_points : int
        At least 1.

    Returns
    -------
    (n_kept,) int64
        Sorted indices into ``points``, ``n_kept <= max_points``; all of them
        when there are no more than ``max_points`` points.
    """
    if len(points) <= max_points:
        return np.arange(len(points), dtype=np.int64)
    low = points.min(axis=0)
    high = points.max(axis=0)
    extent = float((high - low).max())

    def side(k: int) -> float:
        return float(max_points ** (-1.0 / 3.0) * 1.25 ** np.float64(k))

    def firsts(k: int) -> NDArray[np.int64]:
        return np.unique(_cell_keys(points, low, high, extent, side(k)), return_index=True)[1]

    k = 0
    first = firsts(k)
    if len(first) > max_points:
        while len(first) > max_points:
            k += 1
            first = firsts(k)
    else:
        while side(k - 1) >= _FINEST_SIDE:
            finer = firsts(k - 1)
            if len(finer) > max_points:
                break
            k, first = k - 1, finer
    return np.sort(first).astype(np.int64)


_FINEST_SIDE = 1e-6
"""The finest cell side of :func:`voxel_subset`, a share of the extent: ``10^6`` cells an
axis, so a cell's key (``< 10^18``) fits an int64."""


def _cell_keys(points: NDArray[np.float64], low: NDArray[np.float64], high: NDArray[np.float64],
               extent: float, side: float) -> NDArray[np.int64]:
    """The row-major index of each point's cell (:func:`voxel_subset`), one axis at a time.

    A point's cell along an axis is ``floor(((p - low) / extent) / side)`` (0 when
    ``extent`` is 0), at most that of ``high``; one int64 key per point, built
    column by column, holds no ``(n_points, 3)`` temporary, and equal keys are
    equal cells.
    """
    keys = np.zeros(len(points), dtype=np.int64)
    for axis in range(3):
        if extent > 0:
            cells = np.floor((points[:, axis] - low[axis]) / extent / side).astype(np.int64)
            size = int(np.floor((high[axis] - low[axis]) / extent / side)) + 1
        else:
            cells, size = np.zeros(len(points), dtype=np.int64), 1
        keys *= size
        keys += cells
    return keys


def _on_one_line(points: NDArray[np.float64]) -> bool:
    """Whether ``points`` lie on a line (or at one point) up to rounding (class Notes)."""
    extent = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    if len(points) < 3 or extent == 0.0:
        return True
    centred = (points - points.mean(axis=0)) / extent
    variances = np.linalg.eigvalsh(centred.T @ centred / len(points))
    return bool(variances[1] <= 1e-10 * variances[2])


def _as_rows(values: ArrayLike, name: str, what: str) -> NDArray[Any]:
    """``values`` copied to ``(n, 3) float64``, or the one message naming ``what``."""
    try:
        rows = np.array(values, dtype=np.float64, copy=True)
    except (TypeError, ValueError) as err:
        raise InputError(f"{name}: {what} cannot be read as float64: {err}") from err
    if rows.ndim != 2 or rows.shape[1] != 3:
        raise InputError(f"{name}: {what} must have shape (n, 3), got {rows.shape}")
    return rows
