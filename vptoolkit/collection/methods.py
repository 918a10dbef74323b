"""What a collection computes for each model: an answer, from one method.

A method is a frozen value with the directions it names (``names``), a JSON
record of its settings (``record``: what decides its answers, so the run's
output folder is named by its digest) and ``method(mesh) -> Answer``:

- :class:`SearchMethod`: the anytime best-view search
  (:func:`vptoolkit.best_view.search.search_best_views`) with one
  :class:`~vptoolkit.best_view.search.SearchSettings`, an optional prior
  named as :func:`vptoolkit.best_view.prior.resolve_prior` takes it; one
  direction per searched measure;
- :class:`MeasureMethod`: every view of a Fibonacci sphere measured
  (:func:`vptoolkit.measures.quality.compute_view_quality`), the exhaustive
  answer; one direction per measure of the paper;
- :class:`ViewSetMethod`: a ``k``-view coverage set
  (:func:`vptoolkit.view_sets.search.measure_view_set`), directions
  ``view_1`` to ``view_k``;
- any other value with these members, e.g. the thumbnails' prediction
  (:class:`vptoolkit.pictures.thumbnails.PredictedMethod`), which runs in
  the calling process only.

Every answer carries the camera of each direction: the camera-to-world
pose ``(4, 4)`` in the OpenCV convention (x right, y down, z forward, model
units, as :meth:`vptoolkit.best_view.answer.BestViews.camera_pose`), with
``PICTURE_UP`` (+y, or a search's ``up``) at the top of the image, and the
pinhole matrix ``(3, 3)`` of a square image of the method's resolution.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.best_view.search import SearchSettings
from vptoolkit.camera import Camera
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.mesh import Mesh
from vptoolkit.point_cloud import PointCloud
from vptoolkit.settings import MeasureSettings

__all__ = ["Answer", "Method", "MeasureMethod", "SearchMethod", "ViewSetMethod", "cameras"]


@dataclass(frozen=True)
class Answer:
    """A method's answer for one model.

    Attributes
    ----------
    directions : (n, 3) float64
        One unit direction per name of the method, model centre towards the camera.
    raw : (n,) float64
        The measure's raw value in each direction (a view set: its coverage
        after each pick); NaN where there is none.
    poses : (n, 4, 4) float64
        Camera-to-world pose of each direction, OpenCV convention, model units.
    intrinsics : (3, 3) float64
        Pinhole matrix of a square image of the method's resolution, in pixels.
    views : int
        Views drawn to find the answer (0 for a prediction).
    label : str
        One line saying what the answer is, e.g. ``best VE (64 views)``.
    detail : object
        What a drawer needs beyond the directions (a view set's
        :class:`~vptoolkit.view_sets.result.ViewSet`), never stored.
    """

    directions: NDArray[np.float64]
    raw: NDArray[np.float64]
    poses: NDArray[np.float64]
    intrinsics: NDArray[np.float64]
    views: int
    label: str
    detail: Any = field(default=None, compare=False)


class Method(Protocol):
    """What a collection runs on every model."""

    @property
    def names(self) -> tuple[str, ...]:
        """The answer's directions, in row order."""

    @property
    def in_process(self) -> bool:
        """Whether it must run in the calling process (no workers, no scheduler)."""

    def record(self) -> dict[str, Any]:
        """JSON-safe settings that decide the answers."""

    def __call__(self, mesh: Mesh | PointCloud) -> Answer:
        """The answer for one model: a mesh or a point cloud
        (:func:`vptoolkit.collection.runner.read_model`)."""


def cameras(mesh: Mesh | PointCloud, camera: Camera, directions: NDArray[np.float64],
            resolution: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Camera-to-world poses ``(n, 4, 4)`` (OpenCV convention) and the intrinsics ``(3, 3)``
    of a camera looking at ``mesh`` (or a cloud: its points' bounding box) from
    ``directions`` ``(n, 3)``, images of ``resolution`` px."""
    poses = camera.look_at(mesh, directions, resolution=resolution)
    return poses.camera_to_world("opencv"), poses.intrinsics()


@functools.lru_cache(maxsize=4)
def _prior(name: str, measures: tuple[str, ...]
           ) -> Callable[[Mesh | PointCloud], ArrayLike] | None:
    """A named prior, made once per process."""
    from vptoolkit.best_view.prior import resolve_prior

    return resolve_prior(name, measures=measures)


@dataclass(frozen=True)
class SearchMethod:
    """The anytime best-view search of every model.

    Attributes
    ----------
    settings : SearchSettings
        Budget, resolution, coarse pass and camera (default: ``SearchSettings()``).
    measures : tuple of str
        The searched measures (default: the paper's four).
    prior : str
        ``"none"``, ``"unoccluded"``, ``"default"`` or a checkpoint's path
        (:func:`vptoolkit.best_view.prior.resolve_prior`, made once per worker;
        default: "none").
    """

    settings: SearchSettings = field(default_factory=SearchSettings)
    measures: tuple[str, ...] = PAPER_MEASURES
    prior: str = "none"

    @property
    def names(self) -> tuple[str, ...]:
        """The searched measures."""
        return self.measures

    @property
    def in_process(self) -> bool:
        """False: any worker can search."""
        return False

    def record(self) -> dict[str, Any]:
        """``{"method": "search", "settings", "measures", "prior"}``."""
        return {"method": "search", "settings": self.settings.to_dict(),
                "measures": list(self.measures), "prior": self.prior}

    def __call__(self, mesh: Mesh | PointCloud) -> Answer:
        """The search's best direction per measure."""
        from vptoolkit.best_view.search import search_best_views

        prior = _prior(self.prior, self.measures)
        candidates = None if prior is None else prior(mesh)
        found = search_best_views(mesh, self.settings, prior=candidates, measures=self.measures)
        poses = np.stack([found.camera_pose(name) for name in self.measures])
        return Answer(found.directions, found.raw, poses, found.intrinsics(), found.n_views,
                      f"searched {', '.join(self.measures)} ({found.n_views} views)")


@dataclass(frozen=True)
class MeasureMethod:
    """Every view of a Fibonacci sphere measured: the exhaustive answer.

    Attributes
    ----------
    settings : MeasureSettings
        Views, resolution and camera (default: ``MeasureSettings()``, 1000
        views at 1024 px).
    """

    settings: MeasureSettings = field(default_factory=MeasureSettings)

    @property
    def names(self) -> tuple[str, ...]:
        """The paper's four measures."""
        return PAPER_MEASURES

    @property
    def in_process(self) -> bool:
        """False: any worker can measure."""
        return False

    def record(self) -> dict[str, Any]:
        """``{"method": "measure", "settings"}``."""
        return {"method": "measure", "settings": self.settings.to_dict()}

    def __call__(self, mesh: Mesh | PointCloud) -> Answer:
        """The best measured view per measure."""
        from vptoolkit.measures.quality import compute_view_quality

        quality = compute_view_quality(mesh, self.settings)
        directions = quality.best_views
        raw = quality.raw[quality.best_index, np.arange(len(PAPER_MEASURES))]
        poses, intrinsics = cameras(mesh, self.settings.camera, directions,
                                     self.settings.resolution)
        return Answer(directions, raw, poses, intrinsics, self.settings.views,
                      f"best of {len(quality.views)} views")


@dataclass(frozen=True)
class ViewSetMethod:
    """A coverage set of ``k`` views of every model, from one measured sphere.

    Attributes
    ----------
    k : int
        Views in the set.
    settings : MeasureSettings
        The sphere the set is chosen from (default: ``MeasureSettings()``).
    """

    k: int
    settings: MeasureSettings = field(default_factory=MeasureSettings)

    @property
    def names(self) -> tuple[str, ...]:
        """``view_1`` to ``view_k``."""
        return tuple(f"view_{number}" for number in range(1, self.k + 1))

    @property
    def in_process(self) -> bool:
        """False: any worker can measure."""
        return False

    def record(self) -> dict[str, Any]:
        """``{"method": "view_set", "k", "settings"}``."""
        return {"method": "view_set", "k": self.k, "settings": self.settings.to_dict()}

    def __call__(self, mesh: Mesh | PointCloud) -> Answer:
        """The set's directions; ``raw`` is the covered fraction after each pick."""
        from vptoolkit.view_sets.search import measure_view_set

        _, view_set = measure_view_set(mesh, self.k, settings=self.settings)
        directions = np.zeros((self.k, 3))
        raw = np.full(self.k, np.nan)
        poses = np.zeros((self.k, 4, 4))
        chosen = len(view_set)
        directions[:chosen] = view_set.directions
        raw[:chosen] = view_set.coverage
        poses[:chosen], intrinsics = cameras(mesh, self.settings.camera, view_set.directions,
                                              self.settings.resolution)
        return Answer(directions, raw, poses, intrinsics, self.settings.views,
                      f"view set of {chosen} ({100 * view_set.coverage[-1]:.1f} % seen)",
                      detail=view_set)
