"""One measuring session: a model prepared once, a list of measures, asked for any views.

A :class:`MeasuringSession` holds what measuring the views of one model
shares between calls: the model, its element areas, the drawing (one
:class:`~vptoolkit.visibility.RasterScene` for a mesh and the ``"raster"``
backend, one :class:`~vptoolkit.visibility.splats.PointScene` for a point
cloud), the
requested measures (:mod:`vptoolkit.measures.registry`) and the values of the
mesh alone (its curvature, face neighbours, Lee et al.'s saliency, in
:attr:`MeasuringSession.mesh_cache`). :meth:`MeasuringSession.measure` draws
the given directions at a resolution and returns the raw values ``(n, M)``,
one column per measure.

The model is a mesh, whose elements are its faces, or a point cloud, whose
elements are its points: each point is drawn as a splat and weighs the area
of surface it stands for (:func:`vptoolkit.point_areas.point_areas`) where a
face weighs its area, so every measure of the pixel counts runs unchanged;
the measures that read depth, silhouettes or a curvature of faces are refused
for a cloud (:func:`vptoolkit.measures.registry.point_measures`). A cloud's
normals, when it has them, orient the splats (flattened along the normal) and
cull the points facing away from the camera when the camera culls back
faces; without normals the splats are balls and nothing is culled: the
splats nearer the camera hide the far side of the surface all the same, so
no normal is estimated.

Each measure declares the shared pass it reads
(:attr:`Measure.needs <vptoolkit.measures.measure.Measure.needs>`), and the
session runs each needed pass once:

* the paper's four (need ``"sums"``) come from the per-view sums of the
  streamed pixel counts (:func:`vptoolkit.measures.sums.quality_from_histograms`),
  for any subset of them: no view's counts are kept (VMI aside, whose
  ``p(z)`` needs all views first: the counts are kept while they fit in
  :data:`~vptoolkit.measures.sums.STORE_BYTES`, else drawn again; a given
  ``face_probability`` serves instead);
* any other measure reads a :class:`~vptoolkit.measures.data.ViewData` of the
  kept counts, drawn with the depth and silhouette statistics only where a
  requested measure reads them; then the paper's four come from the sums of
  the same kept counts.

:func:`vptoolkit.measures.quality.compute_view_quality`, the best-view search
(:mod:`vptoolkit.best_view.search`) and the view sets
(:mod:`vptoolkit.view_sets.search`) measure through a session.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.geometry import face_areas
from vptoolkit.io import require_surface
from vptoolkit.io.objects import model_of
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure
from vptoolkit.measures.registry import get_measure, point_measures, resolve_measures
from vptoolkit.measures.sums import PAPER_COLUMNS, quality_from_histograms
from vptoolkit.mesh import Mesh
from vptoolkit.point_cloud import PointCloud
from vptoolkit.progress import progress_bar
from vptoolkit.settings import MeasureSettings, check_settings
from vptoolkit.sphere import as_directions
from vptoolkit.visibility import RasterScene, ViewHistograms, iter_view_histograms
from vptoolkit.visibility.splats import PointScene

__all__ = ["MeasuringSession", "progress_runs"]


class MeasuringSession:
    """The measuring of one model's views: the model prepared once, the measures chosen once.

    Parameters
    ----------
    model : Mesh, PointCloud or another model object
        The model: anything :func:`vptoolkit.io.objects.model_of` converts
        (a Mesh or PointCloud, a trimesh or Open3D mesh or point cloud,
        ``(vertices, faces)``, an ``(N, 3)`` or ``(N, 6)`` array of points
        with normals).
    measures : str or iterable of str, optional
        What :func:`~vptoolkit.measures.registry.resolve_measures` takes
        (default: the paper's four); the columns of :meth:`measure` follow
        this order. For a point cloud, only the measures defined on points
        (:func:`~vptoolkit.measures.registry.point_measures`).
    settings : MeasureSettings
        The camera, the pixel counting backend and the default resolution
        (default: ``MeasureSettings()``); its number of views is not read.
        A point cloud is splatted whatever the backend.

    Attributes
    ----------
    model : Mesh or PointCloud
        The model.
    names : tuple of str
        The measures' names, in column order.
    measures : tuple of Measure
        The measures, in column order.
    areas : (n_elements,) float64
        True face areas ``A_z`` of a mesh; of a cloud, the area each point
        stands for, ``pi d_k^2 / k`` (:func:`vptoolkit.point_areas.point_areas`).
    sum_columns : list of int
        Columns of the measures computed from the streamed sums (need ``"sums"``).
    view_columns : list of int
        Columns of the measures computed from a ViewData of the kept counts.
    features : bool
        Whether the views are drawn with depth and silhouette statistics.
    mesh_cache : dict
        The values of the mesh alone, computed once per session.

    Examples
    --------
    >>> import trimesh
    >>> from vptoolkit.sphere import fibonacci_sphere
    >>> session = MeasuringSession(trimesh.creation.box(), "VE,NVT")
    >>> session.measure(fibonacci_sphere(20), 64).shape
    (20, 2)
    """

    def __init__(self, model: Mesh | PointCloud | Any, measures: str | Iterable[str] | None = None,
                 settings: MeasureSettings = MeasureSettings()) -> None:
        self.model: Mesh | PointCloud = model_of(model)
        self.settings = check_settings(settings)
        self._scene: RasterScene | None = None
        self._points: PointScene | None = None
        if isinstance(self.model, PointCloud):
            self.names = point_measures(measures, self.model.name)
            try:
                self._points = PointScene(self.model.points, self.model.normals,
                                          self.settings.camera)
            except InputError as err:  # the scene names its arguments, not the cloud
                raise InputError(f"{self.model.name}: {err}") from err
            self.areas = self._points.areas
        else:
            self.names = resolve_measures(measures)
            self.areas = face_areas(self.model)
        self.measures: tuple[Measure, ...] = tuple(get_measure(name) for name in self.names)
        if not float(self.areas.sum()) > 0.0:  # nothing can be seen: bad input
            raise InputError(f"{self.model.name}: the mesh has zero surface area")
        self.sum_columns = [c for c, measure in enumerate(self.measures) if measure.streams]
        self.view_columns = [c for c, measure in enumerate(self.measures) if not measure.streams]
        self.features = any(measure.needs_image_statistics for measure in self.measures)
        self.mesh_cache: dict[str, Any] = {}

    @property
    def n_elements(self) -> int:
        """The elements the pixels are counted for: the mesh's faces or the cloud's points."""
        return len(self.areas)

    @property
    def streams(self) -> bool:
        """Whether every measure comes from the streamed sums (no view's counts are kept)."""
        return not self.view_columns

    def draw(self, directions: ArrayLike, resolution: int | None = None
             ) -> Iterator[ViewHistograms]:
        """The pixel counts of the directions at ``resolution`` (default: the settings'),
        run by run, with the statistics the measures read."""
        resolution = self.settings.resolution if resolution is None else resolution
        if self._points is not None:
            return self._points.histograms(directions, resolution)
        mesh = require_surface(self.model)  # a cloud has its PointScene
        if self.settings.backend == "raster":
            if self._scene is None:
                self._scene = RasterScene(mesh, self.settings.camera)
            return self._scene.histograms(directions, resolution, features=self.features)
        return iter_view_histograms(mesh, replace(self.settings, resolution=resolution),
                                    view_directions=directions, features=self.features)

    def measure(
        self,
        directions: ArrayLike,
        resolution: int | None = None,
        *,
        histograms: Sequence[ViewHistograms] | None = None,
        face_probability: NDArray[np.float64] | None = None,
        columns: Sequence[int] | None = None,
        progress: bool = False,
        require_seen: bool = True,
    ) -> NDArray[np.float64]:
        """Raw values of the measures for the directions, drawn at ``resolution``.

        Parameters
        ----------
        directions : (n, 3) array_like
            Unit view directions, model centre towards the camera.
        resolution : int, optional
            Image side in pixels (default: the settings').
        histograms : sequence of ViewHistograms, optional
            Pixel counts already drawn for exactly these directions at this
            resolution, with the statistics the measures read; nothing is
            drawn then.
        face_probability : (n_faces,) float64, optional
            ``p(z)`` for VMI estimated elsewhere (as the best-view search
            does); by default the one of these views.
        columns : sequence of int, optional
            Compute only these columns (default: all); the others are NaN.
        progress : bool
            Show a progress bar over the views on stderr (default: False).
        require_seen : bool
            Raise when no view sees any face (default: True); else such
            views are NaN (0 for VR).

        Returns
        -------
        raw : (n, M) float64
            One column per measure, in each measure's own units; NaN where
            a measure is undefined for a view (one that sees nothing).

        Raises
        ------
        MeasurementError
            No view sees any face, with ``require_seen``.
        InputError
            Histograms without the statistics a measure needs, a mesh of
            zero area or a ``face_probability`` of the wrong shape.
        """
        views = as_directions(directions, name="view_directions")
        resolution = self.settings.resolution if resolution is None else resolution
        wanted = range(len(self.measures)) if columns is None else columns
        sums = [c for c in wanted if c in self.sum_columns]
        others = [c for c in wanted if c in self.view_columns]
        raw = np.full((len(views), len(self.measures)), np.nan)
        if not len(views):
            return raw
        if histograms is not None and self.features and others \
                and any(run.features is None for run in histograms):
            needing = ", ".join(self.names[c] for c in others
                                if self.measures[c].needs_image_statistics)
            raise InputError(f"histograms: drawn without the depth and silhouette "
                             f"statistics (needed by {needing})")

        def draw() -> Iterable[ViewHistograms]:
            return self.draw(views, resolution) if histograms is None else histograms

        runs: Iterable[ViewHistograms] = draw()
        if others:
            runs = list(progress_runs(runs, len(views), self.model.name) if progress else runs)
        elif progress:
            runs = progress_runs(runs, len(views), self.model.name)
        if sums:
            mutual = any(self.names[c] == "VMI" for c in sums)
            try:
                paper = quality_from_histograms(
                    runs, self.areas, n_views=len(views),
                    recompute=runs if others else draw(),
                    face_probability=face_probability, mutual_information=mutual)
            except MeasurementError:
                if require_seen:
                    raise
            else:
                raw[:, sums] = paper[:, [PAPER_COLUMNS.index(self.names[c]) for c in sums]]
        if others:
            settings = replace(self.settings, views=max(1, len(views)), resolution=resolution)
            data = ViewData(self.model, views, settings, self.areas, list(runs),
                            mesh_cache=self.mesh_cache)
            if not data.seen.any():
                if require_seen:
                    raise MeasurementError("no face is visible from any of the views")
                return raw
            for column in others:
                values = np.asarray(self.measures[column].compute(data), dtype=np.float64)
                if values.shape != (data.n_views,):
                    raise RuntimeError(f"{self.names[column]}: computed shape {values.shape}, "
                                       f"expected ({data.n_views},)")
                raw[:, column] = values
        return raw


def progress_runs(
    runs: Iterable[ViewHistograms], n_views: int, name: str
) -> Iterator[ViewHistograms]:
    """Pass runs of views through while a progress bar on stderr counts the views."""
    with progress_bar(total=n_views, description=name, unit="view", leave=False) as bar:
        for run in runs:
            bar.update(run.n_views)
            yield run
