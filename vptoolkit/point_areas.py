"""The piece of surface each point of a cloud stands for, from its local spacing.

A point cloud samples a surface at a density that varies (a scan is dense
near the scanner and sparse far away); weighting every point alike would
weight the surface by how densely it was sampled. Each point instead gets
the area of surface around it, estimated from the distance to its ``k``-th
nearest neighbour, and a radius, the side of a disc of that area.

The rule
--------
For points drawn independently and uniformly on a surface of area ``A``
(locally a plane, density ``lambda = n / A`` points per unit area), the
number of points within distance ``d`` of a point is Poisson with mean
``lambda pi d**2``, so ``lambda pi d_k**2``, with ``d_k`` the distance to
the ``k``-th nearest neighbour, follows a Gamma(k, 1) law, of mean ``k``.
Hence

.. math::

    A_i = \\frac{\\pi d_{k,i}^2}{k}, \\qquad r_i = \\sqrt{A_i / \\pi} = \\frac{d_{k,i}}{\\sqrt{k}}

is an unbiased estimate of ``1 / lambda``, the area per point: the areas of a
uniform sample of ``n`` points sum to about the surface's area ``A``, with a
relative error of ``1 / sqrt(k n)`` on the sum and ``1 / sqrt(k)`` on each
point. Where the density changes, each point's area follows its own
neighbourhood. Distances are straight (chords), so a strongly curved
neighbourhood reads slightly small; points on the border of an open
surface have neighbours on one side only and read up to about twice their
share, and where two sheets of surface lie closer than ``d_k`` (a thin part)
their points count each other as neighbours and read small.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import check_int
from vptoolkit.errors import InputError
from vptoolkit.optional import require

__all__ = ["NEIGHBOURS", "point_radii", "point_areas"]

NEIGHBOURS = 8
"""Default ``k``: the ``k``-th nearest neighbour sets a point's area (relative error
``1 / sqrt(k)``)."""


def point_radii(points: ArrayLike, *, k: int = NEIGHBOURS) -> NDArray[np.float64]:
    """Radius of the disc of surface each point stands for, ``r_i = d_k / sqrt(k)``.

    Parameters
    ----------
    points : (n, 3) array_like
        The cloud, in model units; at least ``k + 1`` points.
    k : int
        Which nearest neighbour (not counting the point itself) measures the
        spacing (default: :data:`NEIGHBOURS`).

    Returns
    -------
    radii : (n,) float64
        In model units; the module docstring gives the rule. Where ``k``
        points coincide with a point its radius is 0.

    Raises
    ------
    InputError
        If ``points`` is not a finite ``(n, 3)`` array of more than ``k``
        points, or ``k`` is not a positive integer.
    """
    k = check_int(k, "k", minimum=1)
    cloud = np.asarray(points, dtype=np.float64)
    if cloud.ndim != 2 or cloud.shape[1] != 3:
        raise InputError(f"points: expected an (n, 3) array, got shape {cloud.shape}")
    if len(cloud) <= k:
        raise InputError(f"points: {len(cloud)} points, need more than k = {k} to measure spacing")
    if not np.isfinite(cloud).all():
        raise InputError("points: coordinates must be finite")
    spatial = require("scipy.spatial", extra="measures")
    from vptoolkit._numba import numba

    # The points are queried in the tree's leaf order, so that consecutive queries walk
    # the same nodes, over numba's threads, and only the k-th neighbour's distance is
    # kept ((n, 1), not (n, k + 1) distances and indices): the same distances, exactly.
    tree = spatial.cKDTree(cloud)
    leaf_order = tree.indices
    distances = np.empty(len(cloud), dtype=np.float64)
    distances[leaf_order] = tree.query(cloud[leaf_order], k=[k + 1],
                                       workers=numba.get_num_threads())[0][:, 0]
    return distances / math.sqrt(k)


def point_areas(points: ArrayLike, *, k: int = NEIGHBOURS) -> NDArray[np.float64]:
    """Area of surface each point stands for, ``A_i = pi d_k**2 / k`` (:func:`point_radii`).

    Parameters
    ----------
    points : (n, 3) array_like
        The cloud, in model units; at least ``k + 1`` points.
    k : int
        Which nearest neighbour measures the spacing (default: :data:`NEIGHBOURS`).

    Returns
    -------
    areas : (n,) float64
        In squared model units; a uniform sample of a surface sums to about
        its area (the module docstring gives the maths).

    Examples
    --------
    >>> import numpy as np
    >>> square = np.random.default_rng(0).random((20000, 3)) * [1.0, 1.0, 0.0]
    >>> round(float(point_areas(square).sum()), 1)
    1.0
    """
    return np.pi * point_radii(points, k=k) ** 2
