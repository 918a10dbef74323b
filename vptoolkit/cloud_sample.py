"""The point sample a dataset stores for a point cloud: its own points, to a fixed count.

A mesh's stored points are drawn on its faces (:func:`vptoolkit.points.sample_surface`);
a point cloud already is points, so its stored sample is taken from them
(:func:`sample_cloud`), as ``vptool build-dataset`` does for a cloud file.

The rule
--------
With ``N`` points in the cloud and ``n`` wanted:

- ``N >= n``: ``n`` distinct points drawn uniformly without replacement;
- ``N < n``: every point once, and ``n - N`` more drawn uniformly with
  replacement (so some points are stored twice or more);

the chosen points kept in the cloud's order, the draws from a
``numpy.random.Generator`` seeded with ``seed`` only. Each point keeps its
own unit normal when the cloud has normals. A cloud without normals gets
estimated ones (:func:`estimate_normals`): the direction of least spread of
the point and its :data:`NORMAL_NEIGHBOURS` nearest points of the whole cloud
(the eigenvector of the smallest eigenvalue of their covariance), turned to
point away from the cloud's centroid,

.. math::
    n_i = \\operatorname{sign}\\big(e_i \\cdot (p_i - \\bar p)\\big)\\, e_i,

where a point at the centroid keeps ``e_i``. The estimate is a plane fit:
right on smooth surfaces sampled more densely than their curvature, unreliable
at creases and where two sheets lie closer than the neighbourhood, and its
outward sign is only right for shapes that are star-shaped about their
centroid.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import check_int
from vptoolkit.errors import InputError
from vptoolkit.optional import require
from vptoolkit.point_cloud import PointCloud

__all__ = ["NORMAL_NEIGHBOURS", "CloudSample", "estimate_normals", "sample_cloud"]

NORMAL_NEIGHBOURS = 8
"""Nearest points (besides the point itself) of an estimated normal's plane fit."""


class CloudSample(NamedTuple):
    """Points taken from a cloud, with a unit normal each.

    Attributes
    ----------
    points : (n, 3) float64
        Points of the cloud, in model units.
    normals : (n, 3) float64
        Their unit normals: the cloud's own, or estimated (:func:`estimate_normals`).
    """

    points: NDArray[np.float64]
    normals: NDArray[np.float64]


def sample_cloud(cloud: PointCloud, n: int, *, seed: int = 0) -> CloudSample:
    """``n`` points of a cloud with their normals, by the rule of the module docstring.

    Parameters
    ----------
    cloud : PointCloud
        The cloud; its normals are used when it has them.
    n : int
        Number of points wanted, at least 1.
    seed : int
        Seed (>= 0) of the draws; the same cloud, ``n`` and seed give the same
        sample (default: 0).

    Returns
    -------
    CloudSample
        ``points (n, 3) float64`` and ``normals (n, 3) float64``.

    Raises
    ------
    InputError
        If ``cloud`` is not a PointCloud, or ``n`` or ``seed`` is not a
        non-negative integer in range.

    Examples
    --------
    >>> import numpy as np
    >>> square = PointCloud(np.random.default_rng(0).random((50, 3)) * [1.0, 1.0, 0.0])
    >>> sample = sample_cloud(square, 20, seed=1)
    >>> sample.points.shape, bool(np.allclose(np.abs(sample.normals[:, 2]), 1.0))
    ((20, 3), True)
    """
    if not isinstance(cloud, PointCloud):
        raise InputError(f"cloud: expected a PointCloud, got {type(cloud).__name__}")
    n = check_int(n, "n", minimum=1)
    seed = check_int(seed, "seed", minimum=0)
    rng = np.random.default_rng(seed)
    count = cloud.n_points
    if count >= n:
        chosen = np.sort(rng.choice(count, size=n, replace=False))
    else:
        chosen = np.sort(np.concatenate([np.arange(count), rng.integers(0, count, n - count)]))
    points = np.array(cloud.points[chosen])
    if cloud.normals is not None:
        return CloudSample(points, np.array(cloud.normals[chosen]))
    return CloudSample(points, estimate_normals(cloud.points, points))


def estimate_normals(cloud: ArrayLike, at: ArrayLike | None = None, *,
                     k: int = NORMAL_NEIGHBOURS) -> NDArray[np.float64]:
    """Unit normals of points from the plane through their nearest points of a cloud.

    Parameters
    ----------
    cloud : (N, 3) array_like
        All the points, in model units; more than ``k``.
    at : (n, 3) array_like, optional
        The points whose normals are wanted (default: every point of ``cloud``).
    k : int
        Nearest points of ``cloud`` besides the point itself in each fit
        (default: :data:`NORMAL_NEIGHBOURS`).

    Returns
    -------
    normals : (n, 3) float64
        Unit vectors, oriented away from the centroid of ``cloud`` (the
        module docstring gives the rule).

    Raises
    ------
    InputError
        If ``cloud`` has ``k`` points or fewer, or an array is not ``(m, 3)``.
    """
    k = check_int(k, "k", minimum=2)
    points = np.asarray(cloud, dtype=np.float64)
    where = points if at is None else np.asarray(at, dtype=np.float64)
    for array, name in ((points, "cloud"), (where, "at")):
        if array.ndim != 2 or array.shape[1] != 3:
            raise InputError(f"{name}: expected an (n, 3) array, got shape {array.shape}")
    if len(points) <= k:
        raise InputError(f"cloud: {len(points)} points, need more than k = {k} to fit a plane")
    spatial = require("scipy.spatial", extra="measures")
    _, neighbours = spatial.cKDTree(points).query(where, k=k + 1)
    local = points[neighbours]  # (n, k + 1, 3)
    centred = local - local.mean(axis=1, keepdims=True)
    _, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", centred, centred))
    normals = vectors[:, :, 0]  # eigh sorts the eigenvalues in ascending order
    outward = np.einsum("ni,ni->n", normals, where - points.mean(axis=0))
    normals[outward < 0.0] *= -1.0
    return np.asarray(normals / np.linalg.norm(normals, axis=1, keepdims=True))
