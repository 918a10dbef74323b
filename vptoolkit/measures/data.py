"""What the measures read for one model and one set of views.

A :class:`ViewData` holds the drawn pixel counts (and, where asked for, the
per-view depth and silhouette statistics) of every view, and computes the
shared quantities once, on first use: per-view sums, the face distribution
``p(z)``, the per-face curvature and saliency, the neighbouring views. Each
measure of :mod:`vptoolkit.measures.catalog` is a function of it.

Notation as in :mod:`vptoolkit.measures.quality`: ``a_z(v)`` pixels of face
``z`` in view ``v``, ``a_t(v) = sum_z a_z(v)``, ``A_z`` the face's area,
``A_t`` the mesh's area, logarithms in base 2. For a point cloud the
elements are its points: ``a_z(v)`` the pixels of point ``z``'s splat,
``A_z`` the area of surface it stands for.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cached_property
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.mesh import Mesh
from vptoolkit.optional import require
from vptoolkit.point_cloud import PointCloud
from vptoolkit.settings import MeasureSettings
from vptoolkit.visibility import ViewHistograms
from vptoolkit.visibility.features import ViewFeatures

__all__ = ["XLOGX_TABLE_SIZE", "ViewData"]

XLOGX_TABLE_SIZE: Final = 1 << 16
"""Most entries of :attr:`ViewData.xlogx_table`."""


_NEIGHBOUR_MARGIN: Final = 8
"""Candidates beyond ``count + 1`` that the k-d tree gives each view at first."""

_COSINE_SLACK: Final = 1e-12
"""How much lower than the ``count``-th nearest view's cosine the farthest candidate's must be:
well above the rounding of a dot product of unit vectors (about ``1e-16``)."""


class ViewData:
    """The drawn views of one model, and what the measures derive from them.

    Parameters
    ----------
    mesh : Mesh or PointCloud
        The measured model; a cloud's points are its elements ("faces" below).
    views : (n_views, 3) float64
        Unit view directions, model centre towards the camera.
    settings : MeasureSettings
        How the views were drawn.
    areas : (n_faces,) float64
        True face areas ``A_z`` (a cloud's point areas).
    histograms : sequence of ViewHistograms
        Runs of views in order, covering every view; with ``features`` where
        a requested measure needs depth or silhouette statistics.
    mesh_cache : dict, optional
        Room for the values that depend on the mesh alone (its curvature,
        face neighbours, Lee et al.'s saliency), shared by every ViewData of
        one mesh that is given the same dict (a measuring session's); a new
        one by default.
    """

    def __init__(self, mesh: Mesh | PointCloud, views: NDArray[np.float64],
                 settings: MeasureSettings, areas: NDArray[np.float64],
                 histograms: Sequence[ViewHistograms],
                 mesh_cache: dict[str, Any] | None = None) -> None:
        self.mesh = mesh
        self.views = views
        self.settings = settings
        self.areas = areas
        self.histograms = histograms
        self.n_views = int(len(views))
        self.n_faces = int(len(areas))
        self.cache: dict[str, Any] = {}
        """Room for values several measures share (keyed by the module that computes them)."""
        self.mesh_cache: dict[str, Any] = {} if mesh_cache is None else mesh_cache
        """Room for values of the mesh alone, which do not depend on the views."""

    @cached_property
    def entries(self) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
        """Every non-zero ``a_z(v)`` as ``(view, face, pixels)`` arrays, views in order."""
        runs = self.histograms
        first = np.concatenate([np.arange(run.n_views) + run.first_view for run in runs])
        views = np.repeat(first.astype(np.int64), np.concatenate([np.diff(run.offsets)
                                                                  for run in runs]))
        faces = np.concatenate([run.face_ids for run in runs], dtype=np.int64)
        counts = np.concatenate([run.pixel_counts for run in runs], dtype=np.float64)
        return views, faces, counts

    @cached_property
    def entry_xlogx(self) -> NDArray[np.float64]:
        """``a_z(v) log2 a_z(v)`` of every entry of :attr:`entries`."""
        counts = self.entries[2]
        result: NDArray[np.float64] = counts * np.log2(counts)
        return result

    @cached_property
    def view_starts(self) -> NDArray[np.int64]:
        """Entries of view ``v`` are ``view_starts[v]:view_starts[v + 1]`` of :attr:`entries`."""
        starts = np.searchsorted(self.entries[0], np.arange(self.n_views + 1, dtype=np.int64))
        return np.asarray(starts, dtype=np.int64)

    @cached_property
    def xlogx_table(self) -> NDArray[np.float64]:
        """``g(n) = n log2 n`` of the integers ``0 <= n <= 2 max a_z(v)``, ``g(0) = 0``.

        The pixels of two entries summed are such integers; the table stops
        at :data:`XLOGX_TABLE_SIZE` entries, so that it stays in the cache.
        """
        counts = self.entries[2]
        largest = 2 * int(counts.max()) if len(counts) else 0
        n = np.arange(min(largest + 1, XLOGX_TABLE_SIZE), dtype=np.float64)
        table: NDArray[np.float64] = n * np.log2(np.maximum(n, 1.0))
        return table

    def per_view(self, weights: NDArray[np.float64]) -> NDArray[np.float64]:
        """``sum_z w`` per view, for ``weights`` aligned with :attr:`entries`.

        The weights of each view are added in the order of its entries
        (:func:`vptoolkit.measures._kernels.segment_sums`); 0 for a view that
        sees nothing.
        """
        from vptoolkit.measures._kernels import segment_sums

        weights = np.ascontiguousarray(weights, dtype=np.float64)
        if weights.shape != self.entries[2].shape:
            raise ValueError(f"weights of shape {weights.shape}, entries {self.entries[2].shape}")
        return segment_sums(self.view_starts, weights)

    @cached_property
    def projected(self) -> NDArray[np.float64]:
        """``a_t(v)``: covered pixels per view, ``(n_views,)``."""
        return self.per_view(self.entries[2])

    @cached_property
    def seen(self) -> NDArray[np.bool_]:
        """Views that see at least one face, ``(n_views,) bool``."""
        return self.projected > 0

    @cached_property
    def face_totals(self) -> NDArray[np.float64]:
        """``sum_v a_z(v)`` per face, ``(n_faces,)``."""
        _, faces, counts = self.entries
        return np.asarray(np.bincount(faces, weights=counts, minlength=self.n_faces),
                          dtype=np.float64)

    @cached_property
    def face_probability(self) -> NDArray[np.float64]:
        """``p(z) = sum_v a_z(v) / sum_v a_t(v)``, as VMI takes it, ``(n_faces,)``."""
        return self.face_totals / self.face_totals.sum()

    @cached_property
    def view_probability(self) -> NDArray[np.float64]:
        """``p(v) = a_t(v) / sum_v' a_t(v')``, ``(n_views,)``."""
        return self.projected / self.projected.sum()

    @cached_property
    def features(self) -> ViewFeatures:
        """Depth and silhouette statistics of every view.

        Raises
        ------
        RuntimeError
            The views were drawn without them (no requested measure needed them).
        """
        runs = [run.features for run in self.histograms]
        if any(run is None for run in runs):
            raise RuntimeError("the views were drawn without depth and silhouette statistics")
        return ViewFeatures.concatenate([run for run in runs if run is not None])

    def neighbours(self, count: int) -> NDArray[np.int64]:
        """The ``count`` nearest other views of each view by angle, ``(n_views, count)``.

        Ties are broken by the lower view index: row ``v`` is the start of
        ``argsort(-cos(v, .))``, stably, the view itself left out, with
        ``cos(v, u)`` the dot product of the unit view directions summed in
        axis order, so copies of one view tie exactly (a BLAS matrix product
        can round them apart by where they sit in its blocks).

        Notes
        -----
        Memory and time grow as ``n_views * count`` (times ``log n_views``):
        a k-d tree of the unit directions (scipy's ``cKDTree``; the chord
        ``|v - u|`` grows as the angle does) gives ``count`` candidates and a
        margin per view, their cosines are computed exactly and sorted by the
        rule above. A row whose farthest candidate is not clearly farther
        than its ``count``-th nearest view (a tie across the margin) is asked
        again with twice the candidates, so the rows are those of the full
        cosine matrix.
        """
        key = f"neighbours:{count}"
        if key not in self.cache:
            count = max(0, min(count, self.n_views - 1))
            self.cache[key] = (_nearest_views(self.views, count) if count else
                               np.empty((self.n_views, 0), dtype=np.int64))
        result: NDArray[np.int64] = self.cache[key]
        return result


def _nearest_views(views: NDArray[np.float64], count: int) -> NDArray[np.int64]:
    """:meth:`ViewData.neighbours` of ``views`` ``(n, 3)`` unit rows, ``1 <= count < n``."""
    spatial = require("scipy.spatial", extra="measures")
    tree = spatial.cKDTree(views)
    n_views = len(views)
    result = np.empty((n_views, count), dtype=np.int64)
    rows = np.arange(n_views)
    width = count + 1 + _NEIGHBOUR_MARGIN
    while len(rows):
        width = min(width, n_views)
        _, candidates = tree.query(views[rows], k=width)
        candidates = np.asarray(candidates, dtype=np.int64).reshape(len(rows), width)
        cosines = np.einsum("rd,rkd->rk", views[rows], views[candidates])
        boundary = cosines.min(axis=1)  # no view left out is nearer than this, up to rounding
        cosines[candidates == rows[:, None]] = -np.inf  # the view itself
        order = np.lexsort((candidates, -cosines), axis=-1)
        ranked = np.take_along_axis(cosines, order, axis=-1)
        # Complete when every view left out is farther than the count-th kept, beyond rounding.
        is_complete = (width == n_views) | (ranked[:, count - 1] - boundary > _COSINE_SLACK)
        done = rows[is_complete]
        result[done] = np.take_along_axis(candidates, order[:, :count], axis=-1)[is_complete]
        rows = rows[~is_complete]
        width *= 2
    return result
