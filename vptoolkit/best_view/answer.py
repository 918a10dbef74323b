"""What a best-view search returns: the best direction per measure and how it was found.

:class:`BestViews` holds, for one model, the best unit direction per searched
measure (bounding-box centre towards the camera), its raw value at the
search's resolution, the stages drawn (:class:`SearchStage`) and the cameras
of the answers (:meth:`BestViews.camera_pose`: image up at the model's up
axis, +y by default, as Open3D and trimesh; :meth:`BestViews.intrinsics`).
:func:`vptoolkit.best_view.search.search_best_views` makes it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.camera import Convention, ViewPoses
from vptoolkit.conventions import PICTURE_UP
from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES

__all__ = ["BestViews", "SearchStage", "view_records"]


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
        """JSON-safe summary: directions, raw values and camera poses (:meth:`camera_pose`,
        OpenCV, rows of the 4x4 matrix) per measure, the up axis, the intrinsics at
        ``resolution``, stages, seconds."""
        views = view_records(self.poses, self.directions, self.up)
        return {
            "name": self.name,
            "views": self.n_views,
            "resolution": self.resolution,
            "stages": [stage.to_dict() for stage in self.stages],
            "seconds": round(self.seconds, 4),
            "up": list(self.up),
            "intrinsics": self.intrinsics().tolist(),
            "best": {
                measure: {"direction": views[column]["direction"],
                          "raw": float(self.raw[column]),
                          "pose": views[column]["pose"]}
                for column, measure in enumerate(self.measures)
            },
        }
