"""What a best-view search returns: the best direction per measure and how it was found.

:class:`BestViews` holds, for one model, the best unit direction per searched
measure (bounding-box centre towards the camera), its raw value at the
search's resolution, the stages drawn (:class:`SearchStage`) and the cameras
of the answers (:meth:`BestViews.camera_pose`: image up at the model's up
axis, +y by default, as Open3D and trimesh; :meth:`BestViews.intrinsics`).
:func:`vptoolkit.best_view.search.search_best_views` makes it;
:func:`answer_record` is the JSON record of best directions and their cameras
that ``vptool best-view --json`` and ``vptool predict --json`` print per model.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.camera import Convention, ViewPoses
from vptoolkit.conventions import PICTURE_UP
from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES

__all__ = ["BestViews", "SearchStage", "answer_record", "view_records"]


def view_records(poses: ViewPoses, directions: NDArray[np.float64],
                 up: ArrayLike | None) -> list[dict[str, Any]]:
    """JSON-safe records of views: per view its ``direction`` (unit, model centre towards
    the camera, 6 decimals) and ``pose``, the camera-to-world matrix ``(4, 4)`` (rows; OpenCV
    convention, model units) with ``up`` at the top of the image
    (:meth:`~vptoolkit.camera.ViewPoses.camera_to_world`), as ``best-view --json`` prints them.

    Parameters
    ----------
    poses : ViewPoses
        The cameras of the views, one per row of ``directions``.
    directions : (n, 3) float64
        The views' unit directions.
    up : (3,) array_like or None
        Model direction at the top of the image; None keeps the measures' own roll.
    """
    matrices = poses.camera_to_world("opencv", up=up)
    return [{"direction": [round(float(c), 6) for c in direction], "pose": matrix.tolist()}
            for direction, matrix in zip(directions, matrices)]


@dataclass(frozen=True)
class SearchStage:
    """One stage of a search: its name, the views it drew and their resolution in pixels."""

    name: str
    n_views: int
    resolution: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe form."""
        return {"stage": self.name, "views": self.n_views, "resolution": self.resolution}


@dataclass(frozen=True)
class BestViews:
    """The answer of a best-view search for one mesh.

    Attributes
    ----------
    name : str
        Name of the mesh.
    directions : (M, 3) float64
        Best unit direction per measure, bounding-box centre towards the camera.
    raw : (M,) float64
        Raw value of each measure in its best direction, drawn at ``resolution``
        (VMI with the estimated ``p(z)`` of :mod:`vptoolkit.best_view.search`).
    resolution : int
        Image side of the views that decided the answer.
    stages : tuple of SearchStage
        What was drawn, in order.
    seconds : float
        Wall time of the search, and of the prior's proposal (not part of the
        answer's bytes anywhere; :func:`vptoolkit.best_view.run.search_inputs` loads numba's kernels
        before the first mesh, so no mesh's time holds that).
    poses : ViewPoses
        The cameras of ``directions`` at ``resolution`` (:meth:`camera_pose`).
    drawn : (n_views, 3) float64
        Every direction drawn, in the order drawn: the stages' views one after
        the other (``stages[0].n_views`` rows first).
    up : tuple of 3 floats
        The model's up axis (``SearchSettings.up``): the top of the image of
        :meth:`camera_pose`.
    measures : tuple of str
        The searched measures, the row order of ``directions`` and ``raw``
        (default: the paper's four, ``PAPER_MEASURES``).
    """

    name: str
    directions: NDArray[np.float64]
    raw: NDArray[np.float64]
    resolution: int
    stages: tuple[SearchStage, ...]
    seconds: float
    poses: ViewPoses
    drawn: NDArray[np.float64]
    up: tuple[float, float, float] = PICTURE_UP
    measures: tuple[str, ...] = PAPER_MEASURES

    def camera_pose(self, measure: str, *,
                    convention: Convention = "opencv") -> NDArray[np.float64]:
        """Camera-to-world pose ``(4, 4) float64`` of a measure's best view, in model units.

        ``convention``: ``"opencv"`` (default; x right, y down, z forward, as
        Open3D) or ``"opengl"`` (x right, y up, z backward, as trimesh's
        ``scene.camera_transform``); the inverse is the world-to-camera extrinsic
        matrix (:meth:`vptoolkit.camera.ViewPoses.camera_to_world`). The model's
        up axis :attr:`up` (default +y, as Open3D and trimesh) is at the top of
        the image. ``measure`` is a searched one, in any case. Raises InputError.
        """
        folded = [name.upper() for name in self.measures]
        if not isinstance(measure, str) or measure.upper() not in folded:
            raise InputError(f"measure: {measure!r} was not searched (searched: "
                             f"{', '.join(self.measures)})")
        return self.poses.camera_to_world(convention, up=self.up)[folded.index(measure.upper())]

    def intrinsics(self, resolution: int | None = None) -> NDArray[np.float64]:
        """Pinhole matrix ``K`` ``(3, 3) float64`` of a square image of ``resolution`` px
        (default: the search's), as :meth:`vptoolkit.camera.ViewPoses.intrinsics`."""
        return self.poses.intrinsics(resolution)

    @property
    def n_views(self) -> int:
        """Views drawn over all stages: the machine-independent cost."""
        return sum(stage.n_views for stage in self.stages)

    def summary(self) -> dict[str, Any]:
        """JSON-safe summary: the name, views drawn, the resolution, stages and seconds,
        then :func:`answer_record` of the directions (with their raw values)."""
        return {
            "name": self.name,
            "views": self.n_views,
            "resolution": self.resolution,
            "stages": [stage.to_dict() for stage in self.stages],
            "seconds": round(self.seconds, 4),
            **answer_record(self.measures, self.directions, self.poses, up=self.up,
                            raw=self.raw),
        }


def answer_record(measures: Sequence[str], directions: ArrayLike, poses: ViewPoses, *,
                  up: ArrayLike = PICTURE_UP, raw: ArrayLike | None = None) -> dict[str, Any]:
    """The JSON-safe record of one model's best direction per measure and their cameras.

    What ``vptool best-view --json`` and ``vptool predict --json`` print per model.

    Parameters
    ----------
    measures : sequence of str
        Measure names, the row order of ``directions``.
    directions : (M, 3) array_like
        Best unit direction per measure, bounding-box centre towards the camera.
    poses : ViewPoses
        The cameras of ``directions`` (:meth:`vptoolkit.camera.Camera.look_at`).
    up : (3,) array_like
        The model's up axis, the top of every pose's image (default: ``PICTURE_UP``, +y).
    raw : (M,) array_like, optional
        The raw value of each measure in its direction, recorded when given.

    Returns
    -------
    dict
        ``resolution``: the poses' image side in pixels; ``up``: the axis as a
        list; ``intrinsics``: the pinhole matrix ``K``
        ``(3, 3)`` at the poses' resolution, as nested lists; ``best``: per
        measure, ``direction`` (rounded to 6 decimals), ``raw`` (with ``raw``)
        and ``pose``, the OpenCV camera-to-world matrix ``(4, 4)`` in model
        units as nested lists (:meth:`vptoolkit.camera.ViewPoses.camera_to_world`).
    """
    rows = np.asarray(directions, dtype=np.float64).reshape(len(measures), 3)
    values = None if raw is None else np.asarray(raw, dtype=np.float64).reshape(len(measures))
    axis = [float(c) for c in np.asarray(up, dtype=np.float64).reshape(3)]
    best: dict[str, dict[str, Any]] = {}
    for column, (measure, view) in enumerate(zip(measures, view_records(poses, rows, axis))):
        best[measure] = {"direction": view["direction"]}
        if values is not None:
            best[measure]["raw"] = float(values[column])
        best[measure]["pose"] = view["pose"]
    return {"resolution": poses.resolution, "up": axis, "intrinsics": poses.intrinsics().tolist(),
            "best": best}
