"""Viewpoint quality of a mesh over its views: computation, normalisation, ranking.

:func:`compute_view_quality` computes any registered measures
(:mod:`vptoolkit.measures.registry`) through a measuring session
(:mod:`vptoolkit.measures.session`); by default the paper's four, VE, VR,
VKL and VMI, which are streamed from per-view sums of the pixel counts
(:mod:`vptoolkit.measures.sums`) without keeping them (with a second drawing
pass for a large mesh), whichever of them are asked for. Other measures read
a :class:`~vptoolkit.measures.data.ViewData` built once from the kept pixel
counts.

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
<vptoolkit.measures.measure.Measure.higher_is_better>` and the minimum
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
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.files import atomic_write
from vptoolkit.measures.registry import PAPER_MEASURES, get_measure
from vptoolkit.measures.session import MeasuringSession
from vptoolkit.mesh import MeshLike
from vptoolkit.point_cloud import PointCloud
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import as_directions
from vptoolkit.visibility import ViewHistograms

__all__ = [
    "ViewQuality",
    "compute_view_quality",
    "normalize_quality",
    "ranked_views",
]


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
        :data:`~vptoolkit.measures.registry.PAPER_MEASURES`, ``("VE", "VR", "VKL", "VMI")``.
    best_index : (M,) int64
        Index of the best view per measure (the first one on ties).
    worst_index : (M,) int64
        Index of the worst view per measure.
    name : str
        Name of the mesh.
    n_faces : int
        Faces of the mesh that was measured (points of a cloud).
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
    measures: tuple[str, ...] = PAPER_MEASURES

    @property
    def best_views(self) -> NDArray[np.float64]:
        """Best view direction per measure, ``(M, 3) float64``."""
        return self.views[self.best_index]

    @property
    def higher_is_better(self) -> tuple[bool, ...]:
        """For each of :attr:`measures`: is a higher raw value better?"""
        return _higher_is_better(self.measures)

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


def _higher_is_better(names: Sequence[str]) -> tuple[bool, ...]:
    """For each named measure: is a higher raw value better (the registry's word)?"""
    return tuple(get_measure(name).higher_is_better for name in names)


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
        paper's four (:data:`~vptoolkit.measures.registry.PAPER_MEASURES`: the
        largest value is best for VE and VR, the smallest for VKL and VMI).

    Returns
    -------
    (n_views,) intp
        NaN rows last; equal values keep their order (a stable sort).
    """
    higher = (_higher_is_better(PAPER_MEASURES) if higher_is_better is None
              else higher_is_better)[column]
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
        the paper's four in :data:`~vptoolkit.measures.registry.PAPER_MEASURES`
        order (higher is better for VE and VR, not for VKL and VMI; ``M = 4``).

    Returns
    -------
    normalized : (n_views, M) float64
        ``(q - q_worst) / (q_best - q_worst)``, where best is the maximum of
        a column whose higher values are better and the minimum otherwise;
        0 for NaN entries; 1 for every finite entry of a constant column.
    """
    directions = (_higher_is_better(PAPER_MEASURES) if higher_is_better is None
                  else tuple(higher_is_better))
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


def compute_view_quality(
    mesh: MeshLike | PointCloud | Any,
    settings: MeasureSettings = MeasureSettings(),
    *,
    measures: str | Iterable[str] | None = None,
    view_directions: ArrayLike | None = None,
    progress: bool = False,
    histograms: Sequence[ViewHistograms] | None = None,
) -> ViewQuality:
    """Compute viewpoint quality measures of a mesh or a point cloud for every view.

    Parameters
    ----------
    mesh : MeshLike, PointCloud or another model object
        The model, as :class:`~vptoolkit.measures.session.MeasuringSession`
        takes it: a point cloud (a PointCloud, an ``(N, 3)`` / ``(N, 6)``
        array, an Open3D or trimesh point cloud) is splatted, its points the
        elements, and takes only the measures defined on points
        (:func:`~vptoolkit.measures.registry.point_measures`).
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
        An unknown measure name, a measure not defined on points for a cloud,
        or ``histograms`` without the statistics a measure needs.
    MeasurementError
        No view sees any face of the mesh.

    Notes
    -----
    The measures are measured by a
    :class:`~vptoolkit.measures.session.MeasuringSession`: any of the paper's
    four are streamed from the per-view sums of the pixel counts
    (:func:`~vptoolkit.measures.sums.quality_from_histograms`), so a large
    mesh never holds all views' counts. Any other measure asked for draws the
    views once, with the depth and silhouette statistics only if a requested
    measure needs them, keeps the runs in a
    :class:`~vptoolkit.measures.data.ViewData` and computes each measure from
    it; what no requested measure reads is never computed.

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
    session = MeasuringSession(mesh, measures, settings)
    mesh, settings, names = session.model, session.settings, session.names
    if view_directions is None:
        directions = settings.directions()
    else:
        directions = as_directions(view_directions, name="view_directions")
    try:
        raw = session.measure(directions, histograms=histograms, progress=progress)
    except MeasurementError as err:
        raise MeasurementError(f"{mesh.name}: {err}") from err
    except InputError as err:
        raise InputError(f"{mesh.name}: {err}") from err
    normalized = normalize_quality(raw, [measure.higher_is_better for measure in session.measures])
    return ViewQuality(
        views=directions,
        raw=raw,
        normalized=normalized,
        best_index=np.argmax(normalized, axis=0).astype(np.int64),
        worst_index=np.argmin(normalized, axis=0).astype(np.int64),
        name=mesh.name,
        n_faces=session.n_elements,
        resolution=settings.resolution,
        backend=settings.backend,
        camera=settings.camera,
        measures=names,
    )
