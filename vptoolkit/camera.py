"""The pinhole camera that looks at a model from a view direction.

Conventions (defaults from :mod:`vptoolkit.conventions`):

* The camera looks at the bounding-box centre ``c`` from ``eye = c + d v``,
  with ``v`` the unit view direction and ``d = distance_factor * diagonal``.
* Camera frame: ``forward = -v``; ``right = normalise(forward x up)``;
  ``true_up = right x forward``. Where ``v`` is parallel to ``up`` the
  ``fallback_up`` vector is used instead.
* Image: square, ``resolution`` pixels a side; column ``x`` grows along
  ``right`` and row ``y`` grows *against* ``true_up`` (row 0 at the top).
  Pixel ``(x, y)`` is sampled at its centre ``(x + 0.5, y + 0.5)``.
* Projection: perspective with focal length
  ``f = (resolution / 2) / tan(fov / 2)`` pixels, so a camera-frame point
  ``(p_r, p_u, p_f)`` lands on ``(res/2 + f p_r / p_f, res/2 - f p_u / p_f)``.
* Faces are culled when seen from behind: a face is front-facing when the eye
  lies on the side its right-hand-rule normal points to.

For a renderer (:meth:`ViewPoses.camera_to_world`, :meth:`ViewPoses.intrinsics`):

* Image up: the measures draw with ``up = (0, -1, 0)`` (the authors'
  renderer); exported poses put ``PICTURE_UP = (0, 1, 0)`` at the top of the
  image instead, as Open3D, trimesh and glTF do, or any ``up`` asked for
  (:meth:`ViewPoses.turned_up`): the same eye and forward axis, the camera
  turned about it. Turning ``(0, -1, 0)`` to ``(0, 1, 0)`` is half a turn:
  the exported picture is the measures' image rotated by 180 degrees.
* Camera-to-world pose ``T = [[R, eye], [0, 0, 0, 1]]``, a ``(4, 4)`` matrix
  whose rotation columns are the camera axes in model coordinates: a point
  ``p`` of the camera frame is the model point ``R p + eye``. In the
  **OpenCV** convention (Open3D's extrinsics) the axes are ``x = right``,
  ``y = -true_up`` (down the image), ``z = forward`` (into the scene); in the
  **OpenGL** convention (trimesh's ``scene.camera_transform``, pyrender,
  Blender) ``x = right``, ``y = true_up``, ``z = -forward`` (the camera
  looks down ``-z``): ``T_opengl = T_opencv @ diag(1, -1, -1, 1)``. The
  world-to-camera extrinsic matrix is ``inv(T)``.
* Intrinsics ``K = [[f, 0, res/2], [0, f, res/2], [0, 0, 1]]`` map a point
  ``(x, y, z)`` of the OpenCV camera frame to ``(u, v) = (f x / z + res/2,
  f y / z + res/2)``, ``u`` along the columns and ``v`` down the rows, where
  pixel ``(col, row)`` covers ``[col, col + 1) x [row, row + 1)`` and its
  centre is ``(col + 0.5, row + 0.5)``, as above (trimesh's ``Camera.K``
  and OpenGL's viewport say the same). Tools that put pixel centres on
  integers (OpenCV's ``projectPoints``) take ``cx = cy = res/2 - 0.5``.

The whole bounding sphere of the model must lie inside the view frustum
(``distance_factor >= 1 / (2 sin(fov / 2))``); this keeps every model fully in
the picture and every depth positive.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import check_int
from vptoolkit.conventions import DISTANCE_FACTOR, FALLBACK_UP, FOV_DEG, PICTURE_UP, UP
from vptoolkit.errors import InputError
from vptoolkit.geometry import bounding_frame
from vptoolkit.mesh import MeshLike
from vptoolkit.point_cloud import PointCloud
from vptoolkit.sphere import as_directions

__all__ = ["CONVENTIONS", "Camera", "Convention", "ViewPoses"]

Convention = Literal["opencv", "opengl"]
"""Camera frame of a pose: OpenCV (x right, y down, z forward) or OpenGL (x right, y up, z back)."""

CONVENTIONS: tuple[Convention, ...] = ("opencv", "opengl")
"""The camera frames :meth:`ViewPoses.camera_to_world` gives."""


@dataclass(frozen=True)
class ViewPoses:
    """Camera poses for a set of view directions.

    Attributes
    ----------
    eyes : (n_views, 3) float64
        Camera positions in model coordinates.
    right, up, forward : (n_views, 3) float64
        Orthonormal camera axes per view (``forward`` points at the model).
    focal_px : float
        Focal length in pixels for the image resolution the poses were made for.
    resolution : int
        Image side in pixels.
    """

    eyes: NDArray[np.float64]
    right: NDArray[np.float64]
    up: NDArray[np.float64]
    forward: NDArray[np.float64]
    focal_px: float
    resolution: int

    def project(self, view: int, points: ArrayLike) -> NDArray[np.float64]:
        """Project model-space points into pixel coordinates of one view.

        Parameters
        ----------
        view : int
            Index of the view.
        points : (n, 3) array_like
            Points in model coordinates (in front of the camera).

        Returns
        -------
        pixels : (n, 3) float64
            Columns ``x`` (to the right), ``y`` (downwards) in pixels, and the
            depth along ``forward`` in model units.
        """
        relative = np.asarray(points, dtype=np.float64) - self.eyes[view]
        p_r = relative @ self.right[view]
        p_u = relative @ self.up[view]
        p_f = relative @ self.forward[view]
        half = self.resolution / 2.0
        return np.stack(
            [half + self.focal_px * p_r / p_f, half - self.focal_px * p_u / p_f, p_f], axis=1
        )

    def turned_up(self, up: ArrayLike) -> ViewPoses:
        """The same eyes and forward axes, each camera turned about its axis so that ``up``
        points up the image.

        Parameters
        ----------
        up : (3,) array_like
            Model direction shown upwards (normalised here): ``right =
            normalise(forward x up)``, ``true_up = right x forward``. A view
            that looks along ``up`` keeps its own roll.

        Returns
        -------
        ViewPoses
            Same ``eyes``, ``forward``, ``focal_px`` and ``resolution``.
        """
        wanted = np.asarray(up, dtype=np.float64)
        if wanted.shape != (3,) or not np.isfinite(wanted).all() or not wanted.any():
            raise InputError(f"up: must be a finite non-zero 3-vector, got {wanted}")
        right = np.cross(self.forward, _unit(wanted))
        parallel = np.linalg.norm(right, axis=1) < 1e-9
        right[parallel] = self.right[parallel]
        right /= np.linalg.norm(right, axis=1, keepdims=True)
        return replace(self, right=right, up=np.cross(right, self.forward))

    def camera_to_world(self, convention: Convention = "opencv", *,
                        up: ArrayLike | None = PICTURE_UP) -> NDArray[np.float64]:
        """The camera-to-world pose of every view, for a renderer.

        Parameters
        ----------
        convention : {"opencv", "opengl"}
            Camera frame (module docstring): ``"opencv"`` x right, y down,
            z forward (default); ``"opengl"`` x right, y up, z backward.
        up : (3,) array_like or None
            Model direction at the top of the image (:meth:`turned_up`;
            default: ``PICTURE_UP = (0, 1, 0)``, as Open3D and trimesh);
            None keeps the measures' own cameras (image up ``(0, -1, 0)``).

        Returns
        -------
        poses : (n_views, 4, 4) float64
            ``[[R, eye], [0, 0, 0, 1]]``, the columns of ``R`` the camera's
            x, y and z axes in model coordinates; ``np.linalg.inv`` gives the
            world-to-camera extrinsics.

        Raises
        ------
        InputError
            On an unknown convention.
        """
        if convention not in CONVENTIONS:
            raise InputError(f"convention: expected one of {', '.join(CONVENTIONS)}, "
                             f"got {convention!r}")
        cameras = self if up is None else self.turned_up(up)
        flip = 1.0 if convention == "opencv" else -1.0
        poses = np.zeros((len(self.eyes), 4, 4))
        poses[:, :3, 0] = cameras.right
        poses[:, :3, 1] = -flip * cameras.up
        poses[:, :3, 2] = flip * cameras.forward
        poses[:, :3, 3] = cameras.eyes
        poses[:, 3, 3] = 1.0
        return poses

    def intrinsics(self, resolution: int | None = None) -> NDArray[np.float64]:
        """The pinhole matrix ``K`` of the views (the same for all).

        Parameters
        ----------
        resolution : int, optional
            Image side in pixels (default: the poses' own). The field of view
            is fixed, so ``f`` scales with the side: ``f = (res/2) / tan(fov/2)``.

        Returns
        -------
        K : (3, 3) float64
            ``[[f, 0, res/2], [0, f, res/2], [0, 0, 1]]`` in pixels, for points
            in the OpenCV camera frame; pixel ``(col, row)`` has its centre at
            ``(col + 0.5, row + 0.5)`` (module docstring).

        Raises
        ------
        InputError
            If ``resolution`` is not a positive integer.
        """
        side = self.resolution if resolution is None else check_int(resolution, "resolution",
                                                                    minimum=1)
        focal = self.focal_px * side / self.resolution
        return np.array([[focal, 0.0, side / 2.0], [0.0, focal, side / 2.0], [0.0, 0.0, 1.0]])

    def pixel_rays(self, view: int) -> NDArray[np.float32]:
        """Rays through the centre of every pixel of one view, row-major.

        Returns
        -------
        rays : (resolution * resolution, 6) float32
            Origin (the eye) and unit direction per pixel; pixel ``(x, y)`` is
            row ``y * resolution + x``.
        """
        res = self.resolution
        # tangent of the angle of each pixel centre from the optical axis
        centres = ((np.arange(res) + 0.5 - res / 2.0) / self.focal_px).astype(np.float32)
        right, up, forward = (axis.astype(np.float32) for axis in
                              (self.right[view], self.up[view], self.forward[view]))
        directions = (
            forward[None, None, :]
            + centres[None, :, None] * right[None, None, :]
            - centres[:, None, None] * up[None, None, :]
        ).reshape(-1, 3)
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        rays = np.zeros((res * res, 6), dtype=np.float32)
        rays[:, :3] = self.eyes[view]
        rays[:, 3:] = directions
        return rays


@dataclass(frozen=True)
class Camera:
    """Perspective camera conventions shared by the measures and the renderer.

    Parameters
    ----------
    fov_deg : float
        Vertical (and horizontal) field of view in degrees (default: 45).
    distance_factor : float
        Eye distance from the bounding-box centre in bounding-box diagonals
        (default: ``1 / sin(45 deg)``, about 1.414).
    up : tuple of 3 floats
        Image up vector in model coordinates (default: ``(0, -1, 0)``).
    fallback_up : tuple of 3 floats
        Up vector used where a view direction is parallel to ``up``
        (default: ``(0, 0, 1)``).
    cull_back_faces : bool
        Whether faces seen from behind are invisible (default: True).
    """

    fov_deg: float = FOV_DEG
    distance_factor: float = DISTANCE_FACTOR
    up: tuple[float, float, float] = UP
    fallback_up: tuple[float, float, float] = FALLBACK_UP
    cull_back_faces: bool = True

    def __post_init__(self) -> None:
        if not 0.0 < self.fov_deg < 180.0:
            raise InputError(f"fov_deg: must lie in (0, 180) degrees, got {self.fov_deg}")
        minimum = 0.5 / math.sin(math.radians(self.fov_deg) / 2.0)
        if not self.distance_factor >= minimum:
            raise InputError(
                f"distance_factor: {self.distance_factor} puts the camera inside the view "
                f"frustum's reach of the model; at fov {self.fov_deg} deg it must be "
                f">= {minimum:.4f}"
            )
        for name in ("up", "fallback_up"):
            vector = np.asarray(getattr(self, name), dtype=np.float64)
            if vector.shape != (3,) or not np.isfinite(vector).all() or not vector.any():
                raise InputError(f"{name}: must be a finite non-zero 3-vector, got {vector}")
        if abs(float(np.dot(_unit(self.up), _unit(self.fallback_up)))) > 0.99:
            raise InputError("fallback_up: must not be parallel to up")

    @classmethod
    def from_dict(cls, record: dict[str, Any]) -> Camera:
        """The camera of a :meth:`to_dict` record (descriptive keys are ignored)."""
        names = ("fov_deg", "distance_factor", "up", "fallback_up", "cull_back_faces")
        values: dict[str, Any] = {
            name: tuple(record[name]) if isinstance(record[name], list) else record[name]
            for name in names if name in record
        }
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe record of the conventions, stored beside every result."""
        record = asdict(self)
        record["up"] = [float(c) for c in self.up]
        record["fallback_up"] = [float(c) for c in self.fallback_up]
        record["projection"] = "perspective"
        record["target"] = "bounding-box centre"
        record["distance_unit"] = "bounding-box diagonal"
        return record

    def poses(
        self,
        view_directions: ArrayLike,
        *,
        centre: ArrayLike,
        diagonal: float,
        resolution: int,
    ) -> ViewPoses:
        """Camera poses looking at ``centre`` from each view direction.

        Parameters
        ----------
        view_directions : (n_views, 3) array_like
            Directions from the model centre towards the camera (normalised here).
        centre : (3,) array_like
            Target point, the bounding-box centre.
        diagonal : float
            Bounding-box diagonal in model units (> 0).
        resolution : int
            Image side in pixels.

        Returns
        -------
        ViewPoses
        """
        if not diagonal > 0.0:
            raise InputError(f"diagonal: model has zero extent ({diagonal})")
        directions = as_directions(view_directions, name="view_directions")
        forward = -directions
        up = np.broadcast_to(_unit(self.up), forward.shape).copy()
        right = np.cross(forward, up)
        parallel = np.linalg.norm(right, axis=1) < 1e-9
        right[parallel] = np.cross(forward[parallel], _unit(self.fallback_up))
        right /= np.linalg.norm(right, axis=1, keepdims=True)
        true_up = np.cross(right, forward)
        eyes = np.asarray(centre, dtype=np.float64)[None, :] + (
            self.distance_factor * diagonal
        ) * directions
        focal = (resolution / 2.0) / math.tan(math.radians(self.fov_deg) / 2.0)
        return ViewPoses(eyes, right, true_up, forward, focal, int(resolution))

    def look_at(self, mesh: MeshLike | PointCloud, view_directions: ArrayLike, *,
                resolution: int) -> ViewPoses:
        """Camera poses of a mesh's views: :meth:`poses` at its bounding-box centre and diagonal.

        Parameters
        ----------
        mesh : MeshLike or PointCloud
            The model (:func:`vptoolkit.mesh.as_mesh`), or a point cloud (the
            bounding box of its points).
        view_directions : (n_views, 3) array_like
            Directions from the model centre towards the camera.
        resolution : int
            Image side in pixels.

        Returns
        -------
        ViewPoses
            The cameras the measures draw with; its
            :meth:`~ViewPoses.camera_to_world` and :meth:`~ViewPoses.intrinsics`
            hand the cameras to another renderer.
        """
        centre, diagonal = bounding_frame(mesh)
        return self.poses(view_directions, centre=centre, diagonal=diagonal,
                          resolution=resolution)


def _unit(vector: tuple[float, float, float] | NDArray[np.float64]) -> NDArray[np.float64]:
    array = np.asarray(vector, dtype=np.float64)
    return array / np.linalg.norm(array)
