"""The input of a view-set search: every sampled view's per-face pixel counts, drawn once.

:class:`FaceVisibility` keeps the sparse histograms ``a_z(v)`` of
:mod:`vptoolkit.visibility` for all views of one model with the true face
areas ``A_z``, so the searches of :mod:`vptoolkit.view_sets.search` and the
measures (:meth:`FaceVisibility.quality`) read them without drawing again.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import check_int
from vptoolkit.errors import InputError
from vptoolkit.measures.quality import normalize_quality
from vptoolkit.measures.session import MeasuringSession, progress_runs
from vptoolkit.measures.sums import quality_from_histograms
from vptoolkit.mesh import MeshLike
from vptoolkit.point_cloud import PointCloud
from vptoolkit.settings import MeasureSettings, check_settings
from vptoolkit.sphere import as_directions
from vptoolkit.visibility import ViewHistograms

__all__ = ["MIN_PIXELS", "FaceVisibility"]

MIN_PIXELS = 1
"""Pixels a face needs in a view to count as seen by it (the paper's ``a_z(v) > 0``)."""


@dataclass(frozen=True, eq=False)
class FaceVisibility:
    """Per-view, per-face pixel counts of every sampled view of one model.

    Attributes
    ----------
    views : (n_views, 3) float64
        Unit view directions (model centre towards the camera).
    face_areas : (n_faces,) float64
        True face areas ``A_z``.
    runs : tuple of ViewHistograms
        Sparse counts ``a_z(v)`` covering views ``0 .. n_views - 1`` in order
        (as :func:`vptoolkit.visibility.iter_view_histograms` yields them).
    name : str
        Name of the model, for messages.
    """

    views: NDArray[np.float64]
    face_areas: NDArray[np.float64]
    runs: tuple[ViewHistograms, ...]
    name: str = "mesh"

    def __post_init__(self) -> None:
        views = as_directions(self.views, name="views")
        areas = np.asarray(self.face_areas, dtype=np.float64)
        if areas.ndim != 1 or not np.isfinite(areas).all() or (areas < 0).any():
            raise InputError(f"{self.name}: face_areas must be finite, non-negative and 1-D")
        if not areas.sum() > 0:
            raise InputError(f"{self.name}: the mesh has zero surface area")
        runs = tuple(self.runs)
        expected = 0
        for run in runs:
            if run.first_view != expected or run.n_faces != len(areas):
                raise InputError(f"{self.name}: histograms must cover views 0..{len(views) - 1} "
                                 f"in order, for {len(areas)} faces")
            expected += run.n_views
        if expected != len(views):
            raise InputError(f"{self.name}: histograms cover {expected} views, "
                             f"views has {len(views)}")
        object.__setattr__(self, "views", views)
        object.__setattr__(self, "face_areas", areas)
        object.__setattr__(self, "runs", runs)

    @classmethod
    def from_mesh(
        cls,
        mesh: MeshLike | PointCloud | Any,
        settings: MeasureSettings = MeasureSettings(),
        *,
        view_directions: ArrayLike | None = None,
        progress: bool = False,
        measures: str | Iterable[str] | None = None,
    ) -> FaceVisibility:
        """Draw every view of a mesh or a point cloud once and keep its pixel counts.

        Drawn by a :class:`~vptoolkit.measures.session.MeasuringSession`, so a
        point cloud's points (splatted, with their areas) take the faces'
        place. Parameters are those of
        :func:`vptoolkit.measures.quality.compute_view_quality`; ``measures``
        are those the counts will serve (default: the paper's four): where
        one reads depth or silhouette statistics, each run keeps them too,
        and a cloud refuses the measures not defined on points.
        """
        session = MeasuringSession(mesh, measures, check_settings(settings))
        directions = (session.settings.directions() if view_directions is None
                      else as_directions(view_directions, name="view_directions"))
        runs: Iterable[ViewHistograms] = session.draw(directions)
        if progress:
            runs = progress_runs(runs, len(directions), session.model.name)
        return cls(directions, session.areas, tuple(runs), session.model.name)

    @property
    def n_views(self) -> int:
        """Number of sampled views."""
        return int(len(self.views))

    @property
    def n_faces(self) -> int:
        """Number of faces."""
        return int(len(self.face_areas))

    def quality(self) -> NDArray[np.float64]:
        """Normalised VE, VR, VKL, VMI of every view, ``(n_views, 4) float64`` (1 = best)."""
        raw = quality_from_histograms(self.runs, self.face_areas, n_views=self.n_views)
        return normalize_quality(raw)

    def seen_matrix(self, min_pixels: int = MIN_PIXELS) -> NDArray[np.bool_]:
        """Dense ``(n_views, n_faces) bool``: face ``z`` has ``>= min_pixels`` pixels in view ``v``.

        Dense, so only for few views or small meshes (tests, exhaustive search).
        """
        min_pixels = check_int(min_pixels, "min_pixels", minimum=1)
        return np.concatenate([run.to_dense() >= min_pixels for run in self.runs], axis=0)
