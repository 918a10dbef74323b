"""Per-face saliency of a mesh: from the views (Feixas et al.) and from the curvature (Lee et al.).

Notation as in :mod:`vptoolkit.measures.data`: ``a_z(v)`` pixels of face
``z`` in view ``v``, ``A_z = sum_v a_z(v)`` the face's pixels over all views
(its :attr:`~vptoolkit.measures.data.ViewData.face_totals`), logarithms in
base 2.

Polygonal saliency (Feixas, Sbert and González 2009)
    With the channel of :mod:`vptoolkit.measures.quality`, ``p(v|z) =
    a_z(v) / A_z`` is the distribution of the views that see face ``z``. Two
    neighbouring faces ``z, z'`` differ by the Jensen-Shannon divergence of
    their view distributions, weighted by their probabilities
    ``pi = A_z / (A_z + A_z')``, ``pi' = A_z' / (A_z + A_z')``:

    ``D(z, z') = H(pi p(V|z) + pi' p(V|z')) - pi H(p(V|z)) - pi' H(p(V|z'))``

    in [0, 1] bits, and the saliency of ``z`` is the mean over its
    neighbours ``N(z)``: ``S(z) = (1 / |N(z)|) sum_{z' in N(z)} D(z, z')``.
    Neighbours are the faces that share an edge with ``z``, vertices at the
    same position counting as one (so a triangle soup, as an STL file
    holds it, has its edges); on a point cloud, whose points are its
    elements, the points among each other's :data:`POINT_NEIGHBOURS` nearest
    (:func:`point_neighbours`); and only neighbours seen from some view
    (``A_z' > 0``) count, as in quoniam's ``FeixasSaliency``. A face no view
    sees, or none of whose neighbours is seen, has no saliency (NaN here);
    the measures say which value they give it. With ``x log x`` written
    ``g(x)``, only views that see both faces enter a sum:

    ``D(z, z') = [sum_{v: a_z(v) a_z'(v) > 0} (g(a_z(v)) + g(a_z'(v)) - g(a_z(v) + a_z'(v)))
    + g(A_z + A_z') - g(A_z) - g(A_z')] / (A_z + A_z')``,

    so each pair costs the views that see its first face, whose pixel
    counts are looked up in a dense per-face row of each view.

Mesh saliency (Lee, Varshney and Jacobs 2005)
    Computed on the face centroids ``x_z`` with the per-face mean curvature
    ``H_z`` of :mod:`vptoolkit.measures.curvature`. The Gaussian-weighted
    mean of the curvature at scale ``sigma`` is

    ``G(z, sigma) = sum_{|x_y - x_z| < 2 sigma} H_y w_zy / sum_{|x_y - x_z| < 2 sigma} w_zy``,
    ``w_zy = exp(-|x_y - x_z|^2 / (2 sigma^2))``,

    the saliency at scale ``sigma_i`` is ``S_i(z) = |G(z, sigma_i) - G(z,
    2 sigma_i)|`` for ``sigma_i = i eps``, ``i = 2 .. 6``, ``eps`` 0.3 % of
    the bounding-box diagonal, and the scales are combined after Itti's
    non-linear normalisation: each ``S_i`` is divided by its maximum and
    multiplied by ``(1 - m_i)^2``, ``m_i`` the mean of its other local maxima
    (faces above all their edge neighbours by more than rounding, the global
    maximum left out; 0 if there is none), and ``S = sum_i S_i``. A scale
    whose ``S_i`` is 0 everywhere adds nothing.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, Final, Literal

import numpy as np
from numpy.typing import NDArray

from vptoolkit.geometry import bounding_frame, undirected_edges, welded_faces
from vptoolkit.io import require_surface
from vptoolkit.measures.curvature import mesh_curvature
from vptoolkit.mesh import MeshLike, as_mesh
from vptoolkit.optional import require
from vptoolkit.point_cloud import PointCloud

if TYPE_CHECKING:
    from vptoolkit.measures.data import ViewData

__all__ = [
    "CACHE_KEY",
    "LEE_CACHE_KEY",
    "PAIRS_CACHE_KEY",
    "POINT_NEIGHBOURS",
    "face_neighbours",
    "lee_saliency",
    "mesh_saliency",
    "point_neighbours",
    "polygon_saliency",
]

CACHE_KEY: Final = "saliency"
"""Key of the per-face polygonal saliency (NaN where undefined) in :attr:`ViewData.cache`."""

LEE_CACHE_KEY: Final = "saliency:lee"
"""Key of the per-face mesh saliency of Lee et al. in :attr:`ViewData.mesh_cache`."""

PAIRS_CACHE_KEY: Final = "saliency:pairs"
"""Key of the mesh's :func:`face_neighbours` in :attr:`ViewData.mesh_cache` (both saliencies)."""

POINT_NEIGHBOURS: Final = 6
"""Nearest points a point of a cloud is paired with for the polygonal saliency (about
the six neighbours of a point of an even sampling of a plane)."""

LEE_SCALES: Final = (2.0, 3.0, 4.0, 5.0, 6.0)
"""Lee et al.'s scales ``sigma_i / eps``."""

LEE_EPSILON: Final = 0.003
"""Lee et al.'s ``eps`` as a fraction of the bounding-box diagonal."""

_PEAK_TOLERANCE: Final = 1e-9  # a local maximum stands this far above its neighbours (max = 1)


def face_neighbours(mesh: MeshLike) -> NDArray[np.int64]:
    """Pairs of faces that share an edge.

    Vertices at the same position are one vertex here, so faces of a mesh
    stored as a triangle soup are joined too. An edge with more than two
    faces joins each pair of them.

    Parameters
    ----------
    mesh : MeshLike
        The model.

    Returns
    -------
    pairs : (n_pairs, 2) int64
        ``(z, z')`` with ``z < z'``, each pair once, in increasing order.
    """
    keys = undirected_edges(welded_faces(mesh)[1])[0].ravel()
    order = np.argsort(keys, kind="stable")
    edge, face = keys[order], order // 3
    # The faces of an edge are a run of equal keys: pair the entries `step` apart in a run.
    found = []
    for step in range(1, len(edge)):
        same = edge[:-step] == edge[step:]
        if not same.any():
            break
        found.append(np.stack([face[:-step][same], face[step:][same]], axis=1))
    pairs = np.concatenate(found) if found else np.empty((0, 2), dtype=np.int64)
    pairs = np.sort(pairs[pairs[:, 0] != pairs[:, 1]], axis=1)
    return np.unique(pairs, axis=0).astype(np.int64).reshape(-1, 2)


def point_neighbours(points: NDArray[np.float64], k: int = POINT_NEIGHBOURS
                     ) -> NDArray[np.int64]:
    """Pairs of points either of which is among the ``k`` nearest of the other.

    The neighbours of a point cloud, for the saliency of its points where a
    mesh pairs faces that share an edge (:func:`face_neighbours`). Points
    at the same position are paired like any others.

    Parameters
    ----------
    points : (n_points, 3) float64
        The cloud.
    k : int
        Nearest other points of each point (default: :data:`POINT_NEIGHBOURS`).

    Returns
    -------
    pairs : (n_pairs, 2) int64
        ``(z, z')`` with ``z < z'``, each pair once, in increasing order.
    """
    spatial = require("scipy.spatial", extra="measures")
    count = min(k, len(points) - 1)
    if count < 1:
        return np.empty((0, 2), dtype=np.int64)
    _, nearest = spatial.cKDTree(points).query(points, k=count + 1)
    own = np.repeat(np.arange(len(points), dtype=np.int64), count + 1)
    pairs = np.sort(np.stack([own, np.asarray(nearest, dtype=np.int64).ravel()], axis=1), axis=1)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    return np.unique(pairs, axis=0).astype(np.int64).reshape(-1, 2)


def _mesh_face_neighbours(data: ViewData) -> NDArray[np.int64]:
    """:func:`face_neighbours` of ``data.mesh`` (:func:`point_neighbours` of a cloud),
    kept in ``data.mesh_cache``: :data:`PAIRS_CACHE_KEY`."""
    if PAIRS_CACHE_KEY not in data.mesh_cache:
        model = data.mesh
        data.mesh_cache[PAIRS_CACHE_KEY] = (point_neighbours(model.points)
                                            if isinstance(model, PointCloud)
                                            else face_neighbours(model))
    pairs: NDArray[np.int64] = data.mesh_cache[PAIRS_CACHE_KEY]
    return pairs


def _divergences(data: ViewData, pairs: NDArray[np.int64]) -> NDArray[np.float64]:
    """``D(z, z')`` of each pair of seen faces, ``(n_pairs,)`` (module docstring).

    ``pairs`` are sorted, first face lower. The sum over the views that see
    both faces is :func:`vptoolkit.measures._kernels.pair_divergence_sums`:
    view by view, every entry ``a_z(v)`` looks up ``a_z'(v)`` of each
    neighbour ``z' > z`` in a dense per-face row of the view.
    """
    from vptoolkit.measures._kernels import pair_divergence_sums

    _, faces, counts = data.entries
    n_faces, totals = data.n_faces, data.face_totals
    pair_starts = np.searchsorted(pairs[:, 0], np.arange(n_faces + 1))
    shared = pair_divergence_sums(data.view_starts, faces, counts, data.entry_xlogx,
                                  data.xlogx_table, pair_starts,
                                  np.ascontiguousarray(pairs[:, 1]), n_faces)
    first, second = totals[pairs[:, 0]], totals[pairs[:, 1]]
    joint = first + second
    divergence = (shared + joint * np.log2(joint) - first * np.log2(first)
                  - second * np.log2(second)) / joint
    return np.clip(divergence, 0.0, 1.0)  # rounding only: D is in [0, 1] bits


def polygon_saliency(
    data: ViewData, *, undefined: Literal["nan", "lowest", "highest"] = "nan"
) -> NDArray[np.float64]:
    """Feixas et al.'s saliency of every face from the views, computed once per :class:`ViewData`.

    Parameters
    ----------
    data : ViewData
        The drawn views of the mesh.
    undefined : {"nan", "lowest", "highest"}
        What a face without saliency (no view sees it or any of its edge
        neighbours) gets: NaN, or the lowest or highest saliency of the other
        faces (0 where no face has one).

    Returns
    -------
    saliency : (n_faces,) float64
        ``S(z)`` in [0, 1] bits (module docstring); kept in ``data.cache``
        under :data:`CACHE_KEY` with NaN for the faces without saliency.
    """
    if CACHE_KEY not in data.cache:
        totals = data.face_totals
        pairs = _mesh_face_neighbours(data)
        pairs = pairs[(totals[pairs[:, 0]] > 0) & (totals[pairs[:, 1]] > 0)]
        divergence = _divergences(data, pairs)
        ends = pairs.T.ravel()
        sums = np.bincount(ends, weights=np.tile(divergence, 2), minlength=data.n_faces)
        neighbours = np.bincount(ends, minlength=data.n_faces)
        data.cache[CACHE_KEY] = np.divide(sums, neighbours, out=np.full(data.n_faces, np.nan),
                                          where=neighbours > 0)
    saliency: NDArray[np.float64] = data.cache[CACHE_KEY]
    if undefined == "nan":
        return saliency
    defined = saliency[~np.isnan(saliency)]
    if len(defined) == 0:
        return np.zeros_like(saliency)
    fill = defined.min() if undefined == "lowest" else defined.max()
    return np.where(np.isnan(saliency), fill, saliency)


def _gaussian_means(points: NDArray[np.float64], values: NDArray[np.float64],
                    sigmas: NDArray[np.float64]) -> NDArray[np.float64]:
    """``G(z, sigma)`` of the module docstring for every point and sigma, ``(n_points, n_sigmas)``.

    The points within ``2 max(sigmas)`` of each point are found in a grid of
    cells of that side: those of its own cell and the 26 around it
    (:func:`vptoolkit.measures._kernels.gaussian_sums` adds their weights).
    """
    from vptoolkit.measures._kernels import gaussian_sums

    radius = 2.0 * float(sigmas.max())
    cell = np.floor((points - points.min(axis=0)) / radius).astype(np.int64) + 1
    shape = cell.max(axis=0) + 2
    keys = (cell[:, 0] * shape[1] + cell[:, 1]) * shape[2] + cell[:, 2]
    order = np.argsort(keys, kind="stable")
    offsets = np.array([(dx * shape[1] + dy) * shape[2] + dz
                        for dx, dy, dz in itertools.product((-1, 0, 1), repeat=3)], dtype=np.int64)
    weights, weighted = gaussian_sums(np.ascontiguousarray(points, dtype=np.float64),
                                      np.ascontiguousarray(values, dtype=np.float64),
                                      (2.0 * sigmas) ** 2, -2.0 * sigmas**2, keys, keys[order],
                                      order.astype(np.int64), offsets)
    means: NDArray[np.float64] = weighted / weights  # each point weighs 1 in its own sums
    return means


def _itti_normalised(values: NDArray[np.float64], pairs: NDArray[np.int64]) -> NDArray[np.float64]:
    """``values / max`` times ``(1 - m)^2``, ``m`` the mean of the other local maxima.

    A local maximum is above each of its edge neighbours by more than
    rounding, so that neighbours equal by symmetry are not told apart by it.
    """
    top = int(np.argmax(values))
    if values[top] <= 0.0:
        return np.zeros_like(values)
    scaled = values / values[top]
    around = np.full(len(values), -np.inf)
    np.maximum.at(around, pairs[:, 0], scaled[pairs[:, 1]])
    np.maximum.at(around, pairs[:, 1], scaled[pairs[:, 0]])
    is_peak = scaled > around + _PEAK_TOLERANCE
    is_peak[top] = False
    others = float(scaled[is_peak].mean()) if is_peak.any() else 0.0
    result: NDArray[np.float64] = scaled * (1.0 - others) ** 2
    return result


def lee_saliency(mesh: MeshLike, curvature: NDArray[np.float64], *,
                 pairs: NDArray[np.int64] | None = None) -> NDArray[np.float64]:
    """Lee et al.'s mesh saliency of every face from its mean curvature.

    Parameters
    ----------
    mesh : MeshLike
        The model.
    curvature : (n_faces,) float64
        Mean curvature of every face (as
        :func:`vptoolkit.measures.curvature.face_mean_curvature` gives it).
    pairs : (n_pairs, 2) int64, optional
        :func:`face_neighbours` of ``mesh``, where already computed.

    Returns
    -------
    saliency : (n_faces,) float64
        ``S(z) >= 0`` (module docstring), dimensionless: each scale
        contributes at most 1. All zeros for a mesh with no extent.
    """
    mesh = as_mesh(mesh)
    _, diagonal = bounding_frame(mesh)
    if diagonal == 0.0:
        return np.zeros(mesh.n_faces)
    centroids = mesh.vertices[mesh.faces].mean(axis=1)
    scales = np.asarray(LEE_SCALES)
    sigmas, column = np.unique(np.concatenate([scales, 2.0 * scales]), return_inverse=True)
    means = _gaussian_means(centroids, np.asarray(curvature, dtype=np.float64),
                            LEE_EPSILON * diagonal * sigmas)
    centre, surround = column[:len(scales)], column[len(scales):]
    if pairs is None:
        pairs = face_neighbours(mesh)
    saliency = np.zeros(mesh.n_faces)
    for inner, outer in zip(centre, surround):
        saliency += _itti_normalised(np.abs(means[:, inner] - means[:, outer]), pairs)
    return saliency


def mesh_saliency(data: ViewData) -> NDArray[np.float64]:
    """:func:`lee_saliency` of ``data.mesh``, computed once per :class:`ViewData`.

    The curvature is the shared one of
    :func:`vptoolkit.measures.curvature.mesh_curvature`; the result is kept
    in ``data.mesh_cache`` under :data:`LEE_CACHE_KEY`.

    Returns
    -------
    saliency : (n_faces,) float64
        ``S(z) >= 0`` of every face.
    """
    if LEE_CACHE_KEY not in data.mesh_cache:
        data.mesh_cache[LEE_CACHE_KEY] = lee_saliency(require_surface(data.mesh),
                                                      mesh_curvature(data),
                                                 pairs=_mesh_face_neighbours(data))
    saliency: NDArray[np.float64] = data.mesh_cache[LEE_CACHE_KEY]
    return saliency
