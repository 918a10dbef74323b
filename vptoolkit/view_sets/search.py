"""The greedy searches for view sets (objectives in :mod:`vptoolkit.view_sets`).

:func:`best_view_set` runs one objective over a
:class:`~vptoolkit.view_sets.visibility.FaceVisibility`; :func:`set_coverage`
scores any set; :func:`measure_view_set` draws a mesh once and returns both
its measures and its coverage set.
"""

from __future__ import annotations

import heapq
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import check_int
from vptoolkit.errors import InputError
from vptoolkit.io.objects import model_of
from vptoolkit.measures.quality import (
    ViewQuality,
    compute_view_quality,
)
from vptoolkit.measures.registry import PAPER_MEASURES, canonical_name
from vptoolkit.mesh import MeshLike
from vptoolkit.point_cloud import PointCloud
from vptoolkit.settings import MeasureSettings, check_settings
from vptoolkit.view_sets.result import ViewSet
from vptoolkit.view_sets.visibility import MIN_PIXELS, FaceVisibility

__all__ = ["OBJECTIVES", "best_view_set", "measure_view_set", "set_coverage"]

OBJECTIVES = ("coverage", "information", "quality")
"""Objectives of :func:`best_view_set` (see :mod:`vptoolkit.view_sets`)."""

_TOLERANCE = 0.05  # near-tie band of the "quality" objective


class _Entries:
    """Constant-time access to one view's entries across the runs.

    ``uncovered`` arrays below are ``(n_faces,) float64``: ``A_z`` for a face
    no chosen view has seen yet, else 0; a view's gain is their sum over its
    seen faces.
    """

    def __init__(self, visibility: FaceVisibility, min_pixels: int) -> None:
        self.runs = visibility.runs
        self.min_pixels = min_pixels
        self.where: list[tuple[int, int, int]] = []
        for which, run in enumerate(self.runs):
            bounds = run.offsets.tolist()
            self.where.extend((which, bounds[i], bounds[i + 1]) for i in range(run.n_views))

    def seen(self, view: int) -> NDArray[np.int32]:
        """Faces with at least ``min_pixels`` pixels in ``view``."""
        which, start, stop = self.where[view]
        run = self.runs[which]
        ids = run.face_ids[start:stop]
        if self.min_pixels > 1:
            ids = ids[run.pixel_counts[start:stop] >= self.min_pixels]
        return ids

    def entries(self, view: int) -> tuple[NDArray[np.int32], NDArray[np.float64]]:
        """Every face of ``view`` with its pixel count."""
        which, start, stop = self.where[view]
        run = self.runs[which]
        return run.face_ids[start:stop], run.pixel_counts[start:stop].astype(np.float64)

    def gain(self, view: int, uncovered: NDArray[np.float64]) -> float:
        """Area of the faces ``view`` sees that are not covered yet."""
        return float(uncovered[self.seen(view)].sum())

    def cover(self, view: int, uncovered: NDArray[np.float64]) -> None:
        uncovered[self.seen(view)] = 0.0

    def reachable(self, n_faces: int) -> NDArray[np.bool_]:
        """Faces some view sees, ``(n_faces,) bool``."""
        seen = np.zeros(n_faces, dtype=np.bool_)
        for run in self.runs:
            ids = run.face_ids
            seen[ids if self.min_pixels == 1 else ids[run.pixel_counts >= self.min_pixels]] = True
        return seen


def _stop(picked: int, covered: float, k: int, target: float | None) -> bool:
    return picked >= k or (target is not None and covered >= target)


def _greedy_coverage(entries: _Entries, areas: NDArray[np.float64], k: int,
                     target: float | None) -> tuple[list[int], list[float]]:
    """Lazy greedy (Minoux 1978): gains only shrink, so an old gain bounds the new one.

    Returns the picks and the covered area after each.
    """
    uncovered = areas.copy()
    heap = [(-np.inf, view, -1) for view in range(len(entries.where))]  # (-bound, view, round)
    picked: list[int] = []
    covered: list[float] = []
    area = 0.0
    while heap and not _stop(len(picked), area, k, target):
        bound, view, evaluated = heapq.heappop(heap)
        if evaluated == len(picked):
            if -bound <= 0.0:
                break  # no view sees anything new
            picked.append(view)
            area += -bound
            covered.append(area)
            entries.cover(view, uncovered)
            continue
        heapq.heappush(heap, (-entries.gain(view, uncovered), view, len(picked)))
    return picked, covered


def _greedy_quality(
    entries: _Entries, areas: NDArray[np.float64], quality: NDArray[np.float64], k: int,
    target: float | None, tolerance: float,
) -> tuple[list[int], list[float]]:
    uncovered = areas.copy()
    first = int(np.argmax(quality))
    picked = [first]
    area = entries.gain(first, uncovered)
    covered = [area]
    entries.cover(first, uncovered)
    bounds = np.full(len(quality), np.inf)  # old gains bound the current ones
    bounds[first] = -1.0
    while not _stop(len(picked), area, k, target):
        best = 0.0
        for view in np.argsort(-bounds, kind="stable").tolist():
            if bounds[view] < (1.0 - tolerance) * best or bounds[view] < 0.0:
                break
            bounds[view] = entries.gain(view, uncovered)
            best = max(best, bounds[view])
        if best <= 0.0:
            break
        # every view left unevaluated gains less than (1 - tolerance) * best
        near = np.flatnonzero(bounds >= (1.0 - tolerance) * best)
        # highest quality, then largest gain, then lowest index
        view = int(near[np.lexsort((near, -bounds[near], -quality[near]))[0]])
        picked.append(view)
        area += float(bounds[view])
        covered.append(area)
        entries.cover(view, uncovered)
        bounds[view] = -1.0
    return picked, covered


def _xlog2x(values: NDArray[np.float64]) -> NDArray[np.float64]:
    logs = np.log2(values, out=np.zeros_like(values), where=values > 0)
    return np.asarray(values * logs, dtype=np.float64)


def _greedy_information(visibility: FaceVisibility, entries: _Entries, k: int,
                        target: float | None) -> tuple[list[int], list[float]]:
    """Greedy on ``H(S)``: per pick one vectorised pass over every entry.

    With ``c(z) = sum_{v in S} a_z(v)``, ``T = sum_z c(z)`` and
    ``K = sum_z c log2 c``, adding ``v`` gives ``H = log2(T') - K'/T'`` with
    ``T' = T + a_t(v)`` and ``K' = K + sum_{z in v} [(c + a) log2(c + a) - c log2 c]``.
    """
    n_views = visibility.n_views
    counts = np.zeros(visibility.n_faces)
    uncovered = visibility.face_areas.copy()
    pixels, sum_c_log_c = 0.0, 0.0
    projected = np.zeros(n_views)  # a_t(v)
    for run in visibility.runs:
        projected[run.first_view:run.first_view + run.n_views] = np.bincount(
            run.view_index(), weights=run.pixel_counts, minlength=run.n_views)
    picked: list[int] = []
    covered: list[float] = []
    area = 0.0
    while not _stop(len(picked), area, k, target):
        change = np.zeros(n_views)
        for run in visibility.runs:
            before = counts[run.face_ids]
            delta = _xlog2x(before + run.pixel_counts) - _xlog2x(before)
            change[run.first_view:run.first_view + run.n_views] = np.bincount(
                run.view_index(), weights=delta, minlength=run.n_views)
        after = pixels + projected
        is_open = after > 0
        is_open[picked] = False
        if not is_open.any():
            break
        entropy = np.full(n_views, -np.inf)
        entropy[is_open] = (np.log2(after[is_open])
                            - (sum_c_log_c + change[is_open]) / after[is_open])
        view = int(np.argmax(entropy))
        picked.append(view)
        ids, pixel_counts = entries.entries(view)
        counts[ids] += pixel_counts
        sum_c_log_c += float(change[view])
        pixels += float(projected[view])
        area += entries.gain(view, uncovered)
        covered.append(area)
        entries.cover(view, uncovered)
    return picked, covered


def set_coverage(
    visibility: FaceVisibility,
    indices: ArrayLike,
    *,
    min_pixels: int = MIN_PIXELS,
) -> NDArray[np.float64]:
    """Cumulative coverage of views taken in the given order.

    Parameters
    ----------
    visibility : FaceVisibility
        The model's pixel counts.
    indices : (k,) array_like of int
        Rows of ``visibility.views``; repeats add nothing.
    min_pixels : int
        Pixels a face needs in a view to count as seen (default: 1).

    Returns
    -------
    coverage : (k,) float64
        ``C({v_1, ..., v_i})`` for ``i = 1 .. k``, fractions of ``A_t``.
    """
    min_pixels = check_int(min_pixels, "min_pixels", minimum=1)
    chosen = np.asarray(indices)
    if chosen.ndim != 1 or chosen.dtype.kind not in "iu":
        raise InputError(f"indices: expected a 1-D array of view indices, got {chosen!r}")
    if len(chosen) and (chosen.min() < 0 or chosen.max() >= visibility.n_views):
        raise InputError(f"indices: must lie in 0..{visibility.n_views - 1}")
    entries = _Entries(visibility, min_pixels)
    uncovered = visibility.face_areas.copy()
    coverage = np.zeros(len(chosen))
    area = 0.0
    for position, view in enumerate(chosen.tolist()):
        area += entries.gain(view, uncovered)
        entries.cover(view, uncovered)
        coverage[position] = area
    return coverage / float(visibility.face_areas.sum())


def _check_k(k: int | None, until_coverage: float | None, n_views: int) -> tuple[int, float | None]:
    if k is None and until_coverage is None:
        raise InputError("k: give a number of views, a coverage target, or both")
    limit = n_views if k is None else check_int(k, "k", minimum=1)
    if until_coverage is not None:
        value = float(until_coverage)
        if not 0.0 < value <= 1.0:
            raise InputError(f"until_coverage: must lie in (0, 1], got {until_coverage}")
        return min(limit, n_views), value
    return min(limit, n_views), None


def best_view_set(
    source: MeshLike | FaceVisibility,
    k: int | None = 4,
    *,
    objective: str = "coverage",
    until_coverage: float | None = None,
    measure: str = "VE",
    tolerance: float = _TOLERANCE,
    min_pixels: int = MIN_PIXELS,
    quality: ArrayLike | None = None,
    settings: MeasureSettings = MeasureSettings(),
) -> ViewSet:
    """Choose views that together show the model, greedily (see the module docstring).

    Parameters
    ----------
    source : MeshLike or FaceVisibility
        A mesh (:func:`~vptoolkit.mesh.as_mesh`; its views are drawn here with
        ``settings``) or pixel counts already drawn.
    k : int or None
        Number of views (default: 4); with ``until_coverage`` the most views.
        Fewer come back when ``k`` exceeds the sampled views, or when no
        view adds coverage any more (``"coverage"``, ``"quality"``).
    objective : {"coverage", "information", "quality"}
        What the greedy search maximises (default: "coverage").
    until_coverage : float, optional
        Stop as soon as the coverage reaches ``until_coverage`` times the
        reachable coverage (that of all sampled views), a value in (0, 1].
    measure : str
        Measure of the ``"quality"`` objective, any registered name in any case
        (default: "VE").
    tolerance : float
        Near-tie band of the ``"quality"`` objective, in [0, 1) (default: 0.05).
    min_pixels : int
        Pixels a face needs in a view to count as seen (default: 1).
    quality : (n_views,) array_like, optional
        Normalised quality of ``measure`` for every view (1 = best), if already
        computed (``"quality"`` only); by default computed from the pixel
        counts for the paper's four, or by
        :func:`~vptoolkit.measures.quality.compute_view_quality` for another
        measure of a mesh (a :class:`FaceVisibility` alone holds only the
        pixel counts, so another measure needs ``quality`` then).
    settings : MeasureSettings
        How a mesh is drawn (default: ``MeasureSettings()``, 1000 views at 1024 px);
        not read for a FaceVisibility.

    Returns
    -------
    ViewSet
        Indices, directions, objective and coverage after each pick.

    Raises
    ------
    InputError
        On an unknown objective or measure, or a bad ``k``, target,
        tolerance or ``min_pixels``.

    Examples
    --------
    >>> from vptoolkit.io import load_mesh
    >>> from vptoolkit.samples import sample_path
    >>> from vptoolkit.settings import MeasureSettings
    >>> views = best_view_set(load_mesh(sample_path("teapot.stl")), 3,
    ...                       settings=MeasureSettings(views=200, resolution=128))
    >>> len(views), bool(views.coverage[-1] > views.coverage[0])
    (3, True)
    """
    if objective not in OBJECTIVES:
        raise InputError(f"objective: expected one of {', '.join(OBJECTIVES)}, got {objective!r}")
    measure = canonical_name(measure)
    min_pixels = check_int(min_pixels, "min_pixels", minimum=1)
    settings = check_settings(settings)
    if not 0.0 <= float(tolerance) < 1.0:
        raise InputError(f"tolerance: must lie in [0, 1), got {tolerance}")
    if isinstance(source, FaceVisibility):
        visibility = source
    else:
        visibility = FaceVisibility.from_mesh(source, settings)
    limit, target = _check_k(k, until_coverage, visibility.n_views)
    entries = _Entries(visibility, min_pixels)
    areas = visibility.face_areas
    total = float(areas.sum())
    reachable = float(areas[entries.reachable(visibility.n_faces)].sum()) / total
    wanted = None if target is None else target * reachable * total * (1.0 - 1e-12)
    if objective == "coverage":
        picked, covered = _greedy_coverage(entries, areas, limit, wanted)
    elif objective == "quality":
        values = (_measure_quality(source, visibility, measure, settings) if quality is None
                  else np.asarray(quality, np.float64))
        if values.shape != (visibility.n_views,):
            raise InputError(f"quality: expected shape ({visibility.n_views},), "
                             f"got {values.shape}")
        picked, covered = _greedy_quality(entries, areas, values, limit, wanted,
                                          float(tolerance))
    else:
        picked, covered = _greedy_information(visibility, entries, limit, wanted)
    indices = np.array(picked, dtype=np.int64)
    coverage = np.array(covered, dtype=np.float64) / total
    score = coverage if objective != "information" else _set_entropy(entries, indices,
                                                                     visibility.n_faces)
    return ViewSet(
        name=visibility.name,
        objective=objective,
        indices=indices,
        directions=visibility.views[indices].copy(),
        score=score.copy(),
        coverage=coverage,
        reachable=reachable,
        n_views=visibility.n_views,
        min_pixels=min_pixels,
        measure=measure if objective == "quality" else None,
    )


def _measure_quality(source: MeshLike | FaceVisibility, visibility: FaceVisibility,
                     measure: str, settings: MeasureSettings) -> NDArray[np.float64]:
    """Normalised values ``(n_views,)`` of one measure over the views of ``visibility``."""
    if measure in PAPER_MEASURES:
        return visibility.quality()[:, PAPER_MEASURES.index(measure)]
    if isinstance(source, FaceVisibility):
        raise InputError(f"measure: {measure} needs the mesh, not only its pixel counts; "
                         "give its normalised values as quality")
    quality = compute_view_quality(source, settings, measures=(measure,),
                                   view_directions=visibility.views)
    return quality.normalized[:, 0]


def _set_entropy(entries: _Entries, indices: NDArray[np.int64],
                 n_faces: int) -> NDArray[np.float64]:
    """``H({v_1, ..., v_i})`` in bits for every prefix of ``indices``."""
    counts = np.zeros(n_faces)
    entropy = np.zeros(len(indices))
    for position, view in enumerate(indices.tolist()):
        ids, pixel_counts = entries.entries(view)
        counts[ids] += pixel_counts
        total = float(counts.sum())
        entropy[position] = np.log2(total) - float(_xlog2x(counts).sum()) / total if total else 0.0
    return entropy


def measure_view_set(
    mesh: MeshLike | PointCloud | Any,
    k: int | None = 4,
    *,
    settings: MeasureSettings = MeasureSettings(),
    progress: bool = False,
    **options: Any,
) -> tuple[ViewQuality, ViewSet]:
    """The paper's four measures (and ``measure``, if another) and a view set of a mesh or a
    point cloud from one drawing of its views.

    Parameters
    ----------
    mesh : MeshLike, PointCloud or another model object
        The model (:func:`vptoolkit.io.objects.model_of`); a cloud's points
        take the faces' place, weighted by the areas they stand for.
    k : int or None
        As for :func:`best_view_set`.
    settings : MeasureSettings
        As for :func:`vptoolkit.measures.quality.compute_view_quality`.
    progress : bool
        Show a progress bar while the views are drawn (default: False).
    **options
        ``objective``, ``until_coverage``, ``measure``, ``tolerance`` and
        ``min_pixels`` of :func:`best_view_set`.

    Returns
    -------
    quality : ViewQuality
        Exactly what :func:`vptoolkit.measures.quality.compute_view_quality` returns.
    view_set : ViewSet
        The set, searched over the same views.
    """
    mesh = model_of(mesh)
    settings = check_settings(settings)
    measure = canonical_name(options.get("measure", "VE"))
    names = PAPER_MEASURES if measure in PAPER_MEASURES else (*PAPER_MEASURES, measure)
    visibility = FaceVisibility.from_mesh(mesh, settings, progress=progress, measures=names)
    quality = compute_view_quality(mesh, settings, measures=names,
                                   view_directions=visibility.views,
                                   histograms=list(visibility.runs))
    options["measure"] = measure
    view_set = best_view_set(visibility, k, quality=quality.normalized[:, names.index(measure)],
                             **options)
    return quality, view_set
