"""Viewpoint quality of a mesh over its views: computation, normalisation, ranking.

:func:`compute_view_quality` computes any registered measures
(:mod:`vptoolkit.measures.registry`); by default the paper's four, VE, VR,
VKL and VMI, which :func:`quality_from_histograms` streams from the pixel
counts without keeping them (with a second drawing pass for a large mesh).
Other measures read a :class:`~vptoolkit.measures.data.ViewData` built once
from the kept pixel counts.

Notation (Bonaventura et al. 2018, as in the paper's section 3): for a view
``v`` and a face ``z``, ``a_z(v)`` is the projected area of ``z`` in pixels
(back faces culled), ``a_t(v) = sum_z a_z(v)`` the projected area of the model
(background excluded), ``A_z`` the true area of ``z`` and ``A_t = sum_z A_z``.
With ``p(z|v) = a_z(v) / a_t(v)`` and logarithms in base 2 (bits):

* VE, viewpoint entropy (eq. 1), higher is better:
  ``VE(v) = -sum_z p(z|v) log2 p(z|v)``
* VR, visibility ratio (eq. 2), higher is better:
  ``VR(v) = sum_z vis_z(v) A_z / A_t`` with ``vis_z(v) = [a_z(v) > 0]``
* VKL, viewpoint Kullback-Leibler divergence (eq. 3), lower is better:
  ``VKL(v) = sum_z p(z|v) log2(p(z|v) A_t / A_z)``
* VMI, viewpoint mutual information (eq. 4), lower is better:
  ``VMI(v) = sum_z p(z|v) log2(p(z|v) / p(z))`` with
  ``p(z) = sum_v p(v) p(z|v)`` and ``p(v) = a_t(v) / sum_v' a_t(v')``, hence
  ``p(z) = sum_v a_z(v) / sum_v a_t(v)`` over the sampled views.

Per model, each measure is normalised to [0, 1] over the sampled views with
1 = best: ``(q - worst) / (best - worst)`` (paper, eq. 5), with best the
maximum where :attr:`Measure.higher_is_better
<vptoolkit.measures.registry.Measure.higher_is_better>` and the minimum
otherwise.

Special cases
    A view that sees no face (every face is back-facing from it) has
    ``VR = 0`` and NaN for VE, VKL and VMI; its normalised value is 0 (worst)
    for all four (other measures state their own value, NaN for most; NaN
    always normalises to 0). A measure that is constant over the views that
    see something normalises to 1 for all of them (every view is best). A
    model that no view sees at all raises
    :class:`~vptoolkit.errors.MeasurementError`.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.camera import Camera
from vptoolkit.checks import check_suffix
from vptoolkit.conventions import HIGHER_IS_BETTER, MEASURES
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.files import atomic_write
from vptoolkit.geometry import face_areas
from vptoolkit.measures.data import ViewData, nonnegative_bits
from vptoolkit.measures.registry import Measure, get_measure, resolve_measures
from vptoolkit.mesh import Mesh, MeshLike, as_mesh
from vptoolkit.progress import progress_bar
from vptoolkit.settings import MeasureSettings, check_settings
from vptoolkit.sphere import as_directions
from vptoolkit.visibility import ViewHistograms, iter_view_histograms

__all__ = [
    "ViewQuality",
    "compute_view_quality",
    "normalize_quality",
    "quality_from_histograms",
    "ranked_views",
]

_STORE_BYTES = 1 << 29  # keep histograms for the VMI pass up to this size, else recompute



@dataclass(frozen=True)
class ViewQuality:
    """Viewpoint quality of one model over a set of views.

    Attributes
    ----------
    views : (n_views, 3) float64
        Unit view directions (model centre towards the camera).
    raw : (n_views, M) float64
        Raw values, one column per name of ``measures``, in each measure's
        own units (bits for VE, VKL, VMI; VR a fraction of the area); NaN
        where a measure is undefined for a view (one that sees nothing).
    normalized : (n_views, M) float64
        Per-model normalised measures in [0, 1], 1 = best.
    measures : tuple of str
        The measures' names, in column order; by default
        :data:`~vptoolkit.conventions.MEASURES`, ``("VE", "VR", "VKL", "VMI")``.
    best_index : (M,) int64
        Index of the best view per measure (the first one on ties).
    worst_index : (M,) int64
        Index of the worst view per measure.
    name : str
        Name of the mesh.
    n_faces : int
        Faces of the mesh that was measured.
    resolution : int
        Image side in pixels.
    backend : str
        ``"raster"`` or ``"raycast"``.
    camera : Camera
        Camera conventions used.
    """

    views: NDArray[np.float64]
    raw: NDArray[np.float64]
    normalized: NDArray[np.float64]
    best_index: NDArray[np.int64]
    worst_index: NDArray[np.int64]
    name: str
    n_faces: int
    resolution: int
    backend: str
    camera: Camera = field(default_factory=Camera)
    measures: tuple[str, ...] = MEASURES

    @property
    def best_views(self) -> NDArray[np.float64]:
        """Best view direction per measure, ``(M, 3) float64``."""
        return self.views[self.best_index]

    @property
    def higher_is_better(self) -> tuple[bool, ...]:
        """For each of :attr:`measures`: is a higher raw value better?"""
        return tuple(get_measure(name).higher_is_better for name in self.measures)

    def summary(self) -> dict[str, Any]:
        """JSON-safe summary: per measure, by name, the best view's index, direction and
        raw value, and which way the measure is better."""
        return {
            "name": self.name,
            "n_faces": self.n_faces,
            "n_views": int(len(self.views)),
            "resolution": self.resolution,
            "backend": self.backend,
            "camera": self.camera.to_dict(),
            "best": {
                measure: {
                    "view_index": int(index),
                    "direction": [round(float(c), 6) for c in self.views[index]],
                    "raw": float(self.raw[index, column]),
                    "higher_is_better": higher,
                }
                for column, (measure, index, higher) in enumerate(
                    zip(self.measures, self.best_index, self.higher_is_better))
            },
        }

    def save_npz(self, path: str | os.PathLike[str]) -> Path:
        """Write the arrays and conventions to an ``.npz`` file atomically.

        The file holds ``views``, ``raw``, ``normalized``, ``measures`` (the
        column names, unicode), ``higher_is_better`` (bool, one per column),
        ``best_index``, ``worst_index``, ``resolution``, ``backend``,
        ``name`` and ``camera`` (a JSON string); nothing needs pickle to load.
        """
        target = check_suffix(path, ".npz")
        with atomic_write(target) as handle:
            np.savez(
                handle,
                views=self.views,
                raw=self.raw,
                normalized=self.normalized,
                measures=np.array(self.measures, dtype=np.str_),
                higher_is_better=np.array(self.higher_is_better, dtype=np.bool_),
                best_index=self.best_index,
                worst_index=self.worst_index,
                resolution=np.int64(self.resolution),
                backend=np.str_(self.backend),
                name=np.str_(self.name),
                camera=np.str_(json.dumps(self.camera.to_dict(), sort_keys=True)),
            )
        return target


def ranked_views(raw: NDArray[np.float64], column: int,
                 higher_is_better: Sequence[bool] | None = None) -> NDArray[np.intp]:
    """Row indices of ``raw`` from the best to the worst value of one measure.

    Parameters
    ----------
    raw : (n_views, M) float64
        Raw values, one column per measure.
    column : int
        The measure's column.
    higher_is_better : sequence of bool, optional
        For each column, whether a higher value is better; by default the
        paper's four (:data:`~vptoolkit.conventions.HIGHER_IS_BETTER`: the
        largest value is best for VE and VR, the smallest for VKL and VMI).

    Returns
    -------
    (n_views,) intp
        NaN rows last; equal values keep their order (a stable sort).
    """
    higher = (HIGHER_IS_BETTER if higher_is_better is None else higher_is_better)[column]
    values = raw[:, column]
    if higher:
        return np.argsort(-np.where(np.isfinite(values), values, -np.inf), kind="stable")
    return np.argsort(np.where(np.isfinite(values), values, np.inf), kind="stable")


def normalize_quality(raw: ArrayLike,
                      higher_is_better: Sequence[bool] | None = None) -> NDArray[np.float64]:
    """Normalise raw measures per column to [0, 1] with 1 = best (eq. 5).

    Parameters
    ----------
    raw : (n_views, M) array_like
        Raw values, one column per measure; NaN marks a view where the
        measure is undefined (one that sees nothing).
    higher_is_better : sequence of M bool, optional
        For each column, whether a higher raw value is better; by default
        the paper's four in :data:`MEASURES` order
        (:data:`~vptoolkit.conventions.HIGHER_IS_BETTER`, so ``M = 4``).

    Returns
    -------
    normalized : (n_views, M) float64
        ``(q - q_worst) / (q_best - q_worst)``, where best is the maximum of
        a column whose higher values are better and the minimum otherwise;
        0 for NaN entries; 1 for every finite entry of a constant column.
    """
    directions = HIGHER_IS_BETTER if higher_is_better is None else tuple(higher_is_better)
    values = np.asarray(raw, dtype=np.float64)
    if values.ndim != 2 or values.shape[1] != len(directions):
        raise InputError(f"raw: expected shape (n_views, {len(directions)}), got {values.shape}")
    normalized = np.zeros_like(values)
    for column, is_higher_better in enumerate(directions):
        finite = np.isfinite(values[:, column])
        if not finite.any():
            continue
        low = values[finite, column].min()
        high = values[finite, column].max()
        span = high - low
        if span <= 1e-12 * max(1.0, abs(high)):
            normalized[finite, column] = 1.0
            continue
        scaled = (values[finite, column] - low) / span
        normalized[finite, column] = scaled if is_higher_better else 1.0 - scaled
    return normalized


def quality_from_histograms(
    histograms: Iterable[ViewHistograms],
    areas: NDArray[np.float64],
    *,
    n_views: int,
    recompute: Iterable[ViewHistograms] | None = None,
    store_bytes: int = _STORE_BYTES,
    face_probability: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Raw measures from per-view histograms, in one streaming pass (or two).

    Everything but VMI follows from per-view sums. VMI's ``p(z)`` needs all
    views first, so the histograms are kept while they fit in
    ``store_bytes``; otherwise they are dropped and ``recompute`` (a second
    iterable over the same views) is consumed for the VMI term. With
    ``face_probability`` given, VMI uses that ``p(z)`` instead and one pass
    suffices.

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

    Returns
    -------
    raw : (n_views, 4) float64
        VE, VR, VKL, VMI in bits (VR a fraction); NaN where ``a_t(v) = 0``.
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
    kept: list[ViewHistograms] | None = [] if face_probability is None else None
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
    if face_probability is None:
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
    elif not np.isfinite(sum_a_log_p_face).all():
        raise InputError("face_probability: a face these views see has p(z) = 0")
    raw = np.full((n_views, len(MEASURES)), np.nan)
    seen = projected > 0
    a_t = projected[seen]
    sum_p_log_p = sum_a_log_a[seen] / a_t - np.log2(a_t)
    raw[:, 1] = visible_area / total_area
    # An entropy and two Kullback-Leibler divergences: exactly 0 for a view of one face
    raw[seen, 0] = nonnegative_bits(-sum_p_log_p)
    raw[seen, 2] = nonnegative_bits(sum_p_log_p + np.log2(total_area) - sum_a_log_area[seen] / a_t)
    raw[seen, 3] = nonnegative_bits(sum_p_log_p - sum_a_log_p_face[seen] / a_t)
    return raw


def compute_view_quality(
    mesh: MeshLike,
    settings: MeasureSettings = MeasureSettings(),
    *,
    measures: str | Iterable[str] | None = None,
    view_directions: ArrayLike | None = None,
    progress: bool = False,
    histograms: Sequence[ViewHistograms] | None = None,
) -> ViewQuality:
    """Compute viewpoint quality measures of a mesh for every view.

    Parameters
    ----------
    mesh : MeshLike
        The model.
    settings : MeasureSettings
        The number of Fibonacci-sphere views, the triangle-ID image side, the
        camera and the pixel counting backend (default: ``MeasureSettings()``,
        1000 views at 1024 px).
    measures : str or iterable of str, optional
        What :func:`~vptoolkit.measures.registry.resolve_measures` takes:
        ``None`` or ``"paper"`` for the paper's four (VE, VR, VKL, VMI, the
        default), ``"all"`` for every registered measure, or names
        (``"VE,NVT,INS"``); the result's columns follow this order.
    view_directions : (n_views, 3) array_like, optional
        Explicit view directions, measured instead of the ``settings.views``
        Fibonacci-sphere directions.
    progress : bool
        Show a progress bar over the views on stderr (default: False).
    histograms : sequence of ViewHistograms, optional
        Pixel counts already drawn for exactly these views with these
        ``settings`` (e.g. kept by
        :func:`vptoolkit.view_sets.search.measure_view_set` for a view set); nothing
        is drawn then. They must carry ``features`` where a requested
        measure needs depth or silhouette statistics.

    Returns
    -------
    ViewQuality
        Raw and normalised measures, best and worst views.

    Raises
    ------
    InputError
        An unknown measure name, or ``histograms`` without the statistics a
        measure needs.
    MeasurementError
        No view sees any face of the mesh.

    Notes
    -----
    The paper's four, asked for in their order, are streamed from the pixel
    counts (:func:`quality_from_histograms`), so a large mesh never holds all
    views' counts. Any other choice draws the views once, with the depth and
    silhouette statistics only if a requested measure needs them, keeps the
    runs in a :class:`~vptoolkit.measures.data.ViewData` and computes each
    measure from it; what no requested measure reads is never computed.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box()
    >>> settings = MeasureSettings(views=100, resolution=64)
    >>> quality = compute_view_quality(box, settings)
    >>> quality.raw.shape, quality.measures
    ((100, 4), ('VE', 'VR', 'VKL', 'VMI'))
    >>> compute_view_quality(box, settings, measures="NVT,PA").measures
    ('NVT', 'PA')
    """
    names = resolve_measures(measures)
    chosen = [get_measure(name) for name in names]
    mesh = as_mesh(mesh)
    settings = check_settings(settings)
    if view_directions is None:
        directions = settings.directions()
    else:
        directions = as_directions(view_directions, name="view_directions")
    areas = face_areas(mesh)
    if not float(areas.sum()) > 0.0:  # nothing can be seen: bad input, as best-view says
        raise InputError(f"{mesh.name}: the mesh has zero surface area")
    with_features = any(measure.needs_image_statistics for measure in chosen)
    if histograms is not None and with_features \
            and any(run.features is None for run in histograms):
        needing = ", ".join(m.name for m in chosen if m.needs_image_statistics)
        raise InputError(f"{mesh.name}: histograms: drawn without the depth and silhouette "
                         f"statistics (needed by {needing})")

    def draw() -> Iterable[ViewHistograms]:
        if histograms is not None:
            return histograms
        return iter_view_histograms(mesh, settings, view_directions=directions,
                                    features=with_features)

    first_pass: Iterable[ViewHistograms] = draw()
    if progress:
        first_pass = progress_runs(first_pass, len(directions), mesh.name)
    try:
        if names == MEASURES:
            raw = quality_from_histograms(
                first_pass, areas, n_views=len(directions), recompute=draw()
            )
        else:
            raw = _registered_quality(mesh, directions, settings, areas, first_pass, chosen)
    except MeasurementError as err:
        raise MeasurementError(f"{mesh.name}: {err}") from err
    except InputError as err:
        raise InputError(f"{mesh.name}: {err}") from err
    normalized = normalize_quality(raw, [measure.higher_is_better for measure in chosen])
    return ViewQuality(
        views=directions,
        raw=raw,
        normalized=normalized,
        best_index=np.argmax(normalized, axis=0).astype(np.int64),
        worst_index=np.argmin(normalized, axis=0).astype(np.int64),
        name=mesh.name,
        n_faces=mesh.n_faces,
        resolution=settings.resolution,
        backend=settings.backend,
        camera=settings.camera,
        measures=names,
    )


def _registered_quality(mesh: Mesh, views: NDArray[np.float64], settings: MeasureSettings,
                        areas: NDArray[np.float64], runs: Iterable[ViewHistograms],
                        chosen: Sequence[Measure]) -> NDArray[np.float64]:
    """Raw values ``(n_views, M)`` of the chosen measures from one pass over the runs."""
    data = ViewData(mesh, views, settings, areas, list(runs))
    if not data.seen.any():
        raise MeasurementError("no face is visible from any of the views")
    columns = []
    for measure in chosen:
        values = np.asarray(measure.compute(data), dtype=np.float64)
        if values.shape != (data.n_views,):
            raise RuntimeError(f"{measure.name}: computed shape {values.shape}, "
                               f"expected ({data.n_views},)")
        columns.append(values)
    return np.column_stack(columns)


def progress_runs(
    runs: Iterable[ViewHistograms], n_views: int, name: str
) -> Iterable[ViewHistograms]:
    """Pass runs of views through while a progress bar on stderr counts the views."""
    with progress_bar(total=n_views, description=name, unit="view", leave=False) as bar:
        for run in runs:
            bar.update(run.n_views)
            yield run
