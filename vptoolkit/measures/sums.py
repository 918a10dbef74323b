"""The paper's four measures from per-view sums of the streamed pixel counts.

VE, VR, VKL and VMI (paper eqs. 1-4) follow from a few sums per view of the
pixel counts ``a_z(v)``, accumulated run by run as the views are drawn, so
no view's counts need to be kept (VMI's ``p(z)`` takes all views first: a
second pass, or the runs kept while they fit). :func:`quality_from_histograms`
is that computation; the measuring session
(:class:`vptoolkit.measures.session.MeasuringSession`) streams it for any
subset of the four, and the catalog's VE, VR, VKL and VMI
(:mod:`vptoolkit.measures.catalog`) compute it once from a
:class:`~vptoolkit.measures.data.ViewData`.

Notation as in :mod:`vptoolkit.measures.quality`, with ``p(z|v) = a_z(v) / a_t(v)``
and logarithms in base 2:

* ``a_t(v) = sum_z a_z(v)``;
* ``sum_z p log2 p = (sum_z a_z log2 a_z) / a_t - log2 a_t``;
* ``VE = -sum_z p log2 p``;
* ``VR = (sum_z [a_z > 0] A_z) / A_t``;
* ``VKL = sum_z p log2 p + log2 A_t - (sum_z a_z log2 A_z) / a_t``;
* ``VMI = sum_z p log2 p - (sum_z a_z log2 p(z)) / a_t`` with
  ``p(z) = sum_v a_z(v) / sum_v a_t(v)``.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.visibility import ViewHistograms

__all__ = [
    "PAPER_COLUMNS",
    "ROUNDING_BITS",
    "STORE_BYTES",
    "nonnegative_bits",
    "quality_from_histograms",
]

PAPER_COLUMNS: Final = ("VE", "VR", "VKL", "VMI")
"""The columns of :func:`quality_from_histograms`, the paper's order."""

STORE_BYTES: Final = 1 << 29
"""Memory in bytes that histograms kept for VMI's second pass may take (512 MiB);
beyond it they are drawn again."""


ROUNDING_BITS: Final = 1e-12
"""Below this many bits an entropy or divergence is rounding of its sums: 0. A view with
pixels of two faces among ``a_t <= 2^30`` has an entropy of at least ``30 / 2^30`` bits."""


def nonnegative_bits(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """An entropy or divergence (never negative) with rounding removed: 0 below
    :data:`ROUNDING_BITS`, NaN kept. A view of one face gets exactly 0, not ``+-1e-15``."""
    with np.errstate(invalid="ignore"):
        return np.where(values < ROUNDING_BITS, 0.0, values)


def quality_from_histograms(
    histograms: Iterable[ViewHistograms],
    areas: NDArray[np.float64],
    *,
    n_views: int,
    recompute: Iterable[ViewHistograms] | None = None,
    store_bytes: int = STORE_BYTES,
    face_probability: NDArray[np.float64] | None = None,
    mutual_information: bool = True,
) -> NDArray[np.float64]:
    """The paper's four raw measures from per-view histograms, in one streaming pass (or two).

    Everything but VMI follows from per-view sums. VMI's ``p(z)`` needs all
    views first, so the histograms are kept while they fit in
    ``store_bytes``; otherwise they are dropped and ``recompute`` (a second
    iterable over the same views) is consumed for the VMI term. With
    ``face_probability`` given, VMI uses that ``p(z)`` instead and one pass
    suffices; without ``mutual_information`` VMI is not computed (NaN), no
    histogram is kept and one pass suffices.

    Parameters
    ----------
    histograms : iterable of ViewHistograms
        Runs of views in order, covering views ``0 .. n_views - 1``.
    areas : (n_faces,) float64
        True face areas ``A_z``.
    n_views : int
        Number of views.
    recompute : iterable of ViewHistograms, optional
        The same histograms again, used only when they did not fit in memory.
    store_bytes : int
        Memory allowed for kept histograms (default: 512 MiB).
    face_probability : (n_faces,) float64, optional
        ``p(z)`` estimated elsewhere (e.g. from a sphere of other views, as
        :mod:`vptoolkit.best_view` does); every face these views see must have
        ``p(z) > 0``.
    mutual_information : bool
        Compute VMI (default: True); the other three do not depend on it.

    Returns
    -------
    raw : (n_views, 4) float64
        VE, VR, VKL, VMI (:data:`PAPER_COLUMNS`) in bits (VR a fraction); NaN
        where ``a_t(v) = 0``.
    """
    total_area = float(areas.sum())
    if not total_area > 0.0:
        raise InputError("areas: the mesh has zero surface area")
    log_areas = np.log2(areas, out=np.full_like(areas, -np.inf), where=areas > 0)
    projected = np.zeros(n_views)  # a_t(v)
    sum_a_log_a = np.zeros(n_views)  # sum_z a_z log2 a_z
    visible_area = np.zeros(n_views)  # sum_z vis_z A_z
    sum_a_log_area = np.zeros(n_views)  # sum_z a_z log2 A_z
    face_totals = np.zeros(len(areas))  # sum_v a_z(v)
    second = mutual_information and face_probability is None  # VMI needs a second pass
    kept: list[ViewHistograms] | None = [] if second else None
    kept_bytes = 0
    sum_a_log_p_face = np.zeros(n_views)  # sum_z a_z log2 p(z)
    if face_probability is not None:
        given = np.asarray(face_probability, dtype=np.float64)
        if given.shape != areas.shape:
            raise InputError(f"face_probability: expected shape {areas.shape}, got {given.shape}")
        log_given = np.log2(given, out=np.full_like(given, -np.inf), where=given > 0)
    for run in histograms:
        views = run.view_index() + run.first_view
        counts = run.pixel_counts.astype(np.float64)
        ids = run.face_ids
        projected += np.bincount(views, weights=counts, minlength=n_views)
        sum_a_log_a += np.bincount(views, weights=counts * np.log2(counts), minlength=n_views)
        visible_area += np.bincount(views, weights=areas[ids], minlength=n_views)
        sum_a_log_area += np.bincount(views, weights=counts * log_areas[ids], minlength=n_views)
        face_totals += np.bincount(ids, weights=counts, minlength=len(areas))
        if face_probability is not None:
            sum_a_log_p_face += np.bincount(views, weights=counts * log_given[ids],
                                            minlength=n_views)
        elif kept is not None:
            kept_bytes += run.nbytes
            if kept_bytes <= store_bytes:
                kept.append(run)
            else:
                kept = None
    if not projected.any():
        raise MeasurementError("no face is visible from any of the views")
    if second:
        log_p_face = np.log2(
            face_totals / face_totals.sum(), out=np.zeros_like(face_totals), where=face_totals > 0
        )
        if kept is None:
            if recompute is None:
                raise InputError("recompute: histograms exceed store_bytes "
                                 "and no second pass was given")
            second_pass: Iterable[ViewHistograms] = recompute
        else:
            second_pass = kept
        for run in second_pass:
            views = run.view_index() + run.first_view
            sum_a_log_p_face += np.bincount(
                views, weights=run.pixel_counts * log_p_face[run.face_ids], minlength=n_views
            )
    elif face_probability is not None and not np.isfinite(sum_a_log_p_face).all():
        raise InputError("face_probability: a face these views see has p(z) = 0")
    raw = np.full((n_views, len(PAPER_COLUMNS)), np.nan)
    seen = projected > 0
    a_t = projected[seen]
    sum_p_log_p = sum_a_log_a[seen] / a_t - np.log2(a_t)
    raw[:, 1] = visible_area / total_area
    # An entropy and two Kullback-Leibler divergences: exactly 0 for a view of one face
    raw[seen, 0] = nonnegative_bits(-sum_p_log_p)
    raw[seen, 2] = nonnegative_bits(sum_p_log_p + np.log2(total_area) - sum_a_log_area[seen] / a_t)
    if mutual_information:
        raw[seen, 3] = nonnegative_bits(sum_p_log_p - sum_a_log_p_face[seen] / a_t)
    return raw
