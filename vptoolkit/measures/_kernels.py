"""Compiled sums of the measures (numba), imported only by the functions that use them.

Each kernel computes a sum that a measure module states in numpy terms, in
the same order of terms, so that it gives the numpy statement's value up to
the rounding of ``log2`` and ``exp``:

* :func:`pair_divergence_sums`: the per-pair sum over shared views of
  Feixas et al.'s polygonal saliency (:mod:`vptoolkit.measures.saliency`);
* :func:`view_pair_sums`: the per-pair sum over shared faces of INS
  (:mod:`vptoolkit.measures.catalog.ins`);
* :func:`gaussian_sums`: the Gaussian-weighted sums of Lee et al.'s mesh
  saliency over a grid of cells (:mod:`vptoolkit.measures.saliency`).

``g(x) = x log2 x`` throughout. ``tests/measures/test_kernels.py`` checks
each kernel against its numpy statement on small cases. The kernels use no
numba code of another module, because numba's on-disk cache checks only the
source file of the function it caches.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from vptoolkit._numba import numba  # noqa: F401  (OpenMP before TBB, see vptoolkit._numba)

__all__ = ["gaussian_sums", "pair_divergence_sums", "segment_sums", "view_pair_sums"]


@njit(cache=True, nogil=True, inline="always")
def _xlogx(value: float, table: NDArray[np.float64]) -> float:
    """``g(value)``, from ``table`` (``g`` of the integers ``0 .. len(table) - 1``) if there."""
    index = int(value)
    if index == value and index < len(table):
        return float(table[index])
    return float(value * np.log2(value))


@njit(cache=True, nogil=True)
def segment_sums(starts: NDArray[np.int64], weights: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sum(weights[starts[i]:starts[i + 1]])`` for each ``i``, added in order from 0."""
    sums = np.zeros(len(starts) - 1)
    for segment in range(len(starts) - 1):
        total = 0.0
        for entry in range(starts[segment], starts[segment + 1]):
            total += weights[entry]
        sums[segment] = total
    return sums


@njit(cache=True, nogil=True)
def pair_divergence_sums(view_starts: NDArray[np.int64], faces: NDArray[np.int64],
                         counts: NDArray[np.float64], logs: NDArray[np.float64],
                         table: NDArray[np.float64], pair_starts: NDArray[np.int64],
                         partners: NDArray[np.int64], n_faces: int) -> NDArray[np.float64]:
    """``sum_{v: a_z(v) a_z'(v) > 0} g(a_z(v)) + g(a_z'(v)) - g(a_z(v) + a_z'(v))`` per face pair.

    Parameters
    ----------
    view_starts : (n_views + 1,) int64
        Entries of view ``v`` are ``view_starts[v]:view_starts[v + 1]`` of
        ``faces``, ``counts`` and ``logs`` (the view-major entries
        ``a_z(v) > 0``).
    faces, counts, logs : (nnz,) int64, float64, float64
        Face ``z``, pixels ``a_z(v)`` and ``g(a_z(v))`` of each entry.
    table : (n,) float64
        ``g`` of the integers ``0 .. n - 1`` (a sum of two pixel counts is
        looked up there when it is such an integer, else computed).
    pair_starts : (n_faces + 1,) int64
        Pairs whose first face is ``z`` are ``pair_starts[z]:pair_starts[z + 1]``.
    partners : (n_pairs,) int64
        Second face ``z'`` of each pair.
    n_faces : int
        Number of faces.

    Returns
    -------
    shared : (n_pairs,) float64
        The sum of each pair, its terms added in increasing view order. One
        view at a time, its pixels and their ``g`` are spread over dense
        per-face rows, and each entry's face looks up its partners' there.
    """
    shared = np.zeros(len(partners))
    row = np.zeros(n_faces)
    row_logs = np.zeros(n_faces)
    for view in range(len(view_starts) - 1):
        start, stop = view_starts[view], view_starts[view + 1]
        for entry in range(start, stop):
            row[faces[entry]] = counts[entry]
            row_logs[faces[entry]] = logs[entry]
        for entry in range(start, stop):
            face = faces[entry]
            for pair in range(pair_starts[face], pair_starts[face + 1]):
                theirs = row[partners[pair]]
                if theirs > 0.0:
                    both = counts[entry] + theirs
                    shared[pair] += logs[entry] + row_logs[partners[pair]] - _xlogx(both, table)
        for entry in range(start, stop):
            row[faces[entry]] = 0.0
    return shared


@njit(cache=True, nogil=True)
def view_pair_sums(view_starts: NDArray[np.int64], faces: NDArray[np.int64],
                   counts: NDArray[np.float64], logs: NDArray[np.float64],
                   table: NDArray[np.float64], walk: NDArray[np.int64], other: NDArray[np.int64],
                   order: NDArray[np.int64], n_faces: int) -> NDArray[np.float64]:
    """``sum_{z: a_z(v) a_z(v') > 0} g(a_z(v) + a_z(v')) - g(a_z(v)) - g(a_z(v'))`` per view pair.

    Parameters
    ----------
    view_starts, faces, counts, logs, table
        The view-major entries and ``g``, as :func:`pair_divergence_sums`
        takes them.
    walk, other : (n_pairs,) int64
        The two views ``v`` (whose entries are walked, in their order) and
        ``v'`` (whose pixels are looked up) of each pair.
    order : (n_pairs,) int64
        The pairs in increasing ``other``, so that each ``v'`` is spread over
        dense per-face rows once.
    n_faces : int
        Number of faces.

    Returns
    -------
    shared : (n_pairs,) float64
        The sum of each pair, its terms added in the order of ``v``'s entries.
    """
    shared = np.zeros(len(walk))
    row = np.zeros(n_faces)
    row_logs = np.zeros(n_faces)
    spread = -1
    for pair in order:
        if other[pair] != spread:
            if spread >= 0:
                for entry in range(view_starts[spread], view_starts[spread + 1]):
                    row[faces[entry]] = 0.0
            spread = other[pair]
            for entry in range(view_starts[spread], view_starts[spread + 1]):
                row[faces[entry]] = counts[entry]
                row_logs[faces[entry]] = logs[entry]
        total = 0.0
        for entry in range(view_starts[walk[pair]], view_starts[walk[pair] + 1]):
            theirs = row[faces[entry]]
            if theirs > 0.0:
                both = counts[entry] + theirs
                total += _xlogx(both, table) - logs[entry] - row_logs[faces[entry]]
        shared[pair] = total
    return shared


@njit(cache=True, nogil=True)
def gaussian_sums(points: NDArray[np.float64], values: NDArray[np.float64],
                  limits: NDArray[np.float64], divisors: NDArray[np.float64],
                  keys: NDArray[np.int64], sorted_keys: NDArray[np.int64],
                  order: NDArray[np.int64], offsets: NDArray[np.int64]
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``sum_y w_zy`` and ``sum_y w_zy H_y`` over ``|x_y - x_z|^2 < limit``, per point and scale.

    ``w_zy = exp(|x_y - x_z|^2 / divisor)`` with ``divisor = -2 sigma^2``.

    Parameters
    ----------
    points : (n, 3) float64
        The points ``x_z``.
    values : (n,) float64
        ``H_y`` of each point.
    limits, divisors : (n_scales,) float64
        ``(2 sigma)^2`` and ``-2 sigma^2`` of each scale.
    keys : (n,) int64
        The grid cell of each point.
    sorted_keys, order : (n,) int64
        ``keys`` sorted (stably) and the points in that order.
    offsets : (n_offsets,) int64
        Key offsets of the cells searched around a point's cell (those
        within the largest limit).

    Returns
    -------
    weights, weighted : (n, n_scales) float64
        The two sums of each point, terms added cell by cell in the order of
        ``offsets``, points of a cell in ``order``.
    """
    n_scales = len(limits)
    weights = np.zeros((len(points), n_scales))
    weighted = np.zeros((len(points), n_scales))
    for near in range(len(points)):
        for offset in offsets:
            key = keys[near] + offset
            low = np.searchsorted(sorted_keys, key, side="left")
            high = np.searchsorted(sorted_keys, key, side="right")
            for slot in range(low, high):
                far = order[slot]
                dx = points[near, 0] - points[far, 0]
                dy = points[near, 1] - points[far, 1]
                dz = points[near, 2] - points[far, 2]
                squared = dx * dx + dy * dy + dz * dz
                for scale in range(n_scales):
                    if squared < limits[scale]:
                        weight = np.exp(squared / divisors[scale])
                        weights[near, scale] += weight
                        weighted[near, scale] += weight * values[far]
    return weights, weighted
