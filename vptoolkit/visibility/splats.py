"""Per-view, per-point visible pixels of a point cloud: the points' :mod:`vptoolkit.visibility`.

Each point stands for a piece of surface of area ``A_i = pi r_i**2``, with
``r_i`` from its local spacing (:mod:`vptoolkit.point_areas`), and is drawn
as a splat of radius ``splat_scale * r_i`` (a spheroid flattened along the
point's normal, a ball without normals) into a z-buffer of point IDs
(:mod:`._splat`), with the camera of :mod:`vptoolkit.camera` aimed at the
bounding box of the points. The pixels of each point in each view come out
as :class:`~vptoolkit.visibility.ViewHistograms` with point indices in
``face_ids`` and the number of points in ``n_faces``, so the measures that
read a mesh's histograms and face areas read a cloud's histograms and
point areas the same way::

    scene = PointScene(points, normals)
    raw = quality_from_histograms(scene.histograms(directions, 256), scene.areas,
                                  n_views=len(directions))

Why solids, and why bigger than ``r_i``: the front surface of overlapping
splats shares the overlaps out as the points' Voronoi cells (:mod:`._splat`),
so a splat larger than the point's own disc takes little from its
neighbours; it must be larger, since discs of exactly the points' areas
leave ``exp(-1)``, about 37 %, of a randomly sampled surface uncovered
(the covered fraction of a Boolean model of discs of mean area ``1 /
lambda`` at density ``lambda``), through which the back of the model would
show. At ``splat_scale = 2`` the uncovered share is ``exp(-4)``, under 2 %,
and the outline grows by about two spacings.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.camera import Camera
from vptoolkit.checks import check_float, check_int
from vptoolkit.conventions import RESOLUTION
from vptoolkit.errors import InputError
from vptoolkit.point_areas import NEIGHBOURS, point_radii
from vptoolkit.settings import MAX_RESOLUTION, MeasureSettings, check_settings
from vptoolkit.sphere import as_directions
from vptoolkit.visibility import _BATCH_BYTES, ViewHistograms, _depth_range

if TYPE_CHECKING:
    from vptoolkit.visibility._workspace import RasterWorkspace

__all__ = ["SPLAT_SCALE", "PointScene", "iter_point_histograms"]

SPLAT_SCALE = 2.0
"""Default ratio of a point's splat radius to the radius of its own piece of surface."""

THICKNESS = 0.5
"""Default thickness of a splat along the point's normal, over its radius (1: a ball)."""


class PointScene:
    """A point cloud prepared once for splatting, drawn in any number of calls.

    Parameters
    ----------
    points : (n_points, 3) array_like
        The cloud in model units, more than ``k`` finite points.
    normals : (n_points, 3) array_like, optional
        Outward normals (any length but 0); where given and the camera culls
        back faces, a point is drawn only in views whose eye lies on the side
        its normal points to. Without normals every point is drawn.
    camera : Camera, optional
        Camera conventions (default: ``Camera()``); it looks at the centre of
        the points' bounding box from a multiple of its diagonal.
    k : int
        The neighbour whose distance sets each point's area (default:
        :data:`vptoolkit.point_areas.NEIGHBOURS`).
    splat_scale : float
        Splat radius over the radius of the point's piece of surface
        (default: :data:`SPLAT_SCALE`; the module docstring says why 2).
    thickness : float
        Splat thickness along the normal over its radius, in (0, 1]
        (default: :data:`THICKNESS`); 1 draws balls. Without normals the
        splats are balls.

    Attributes
    ----------
    areas : (n_points,) float64
        Area of surface each point stands for, ``pi r_i**2``
        (:func:`vptoolkit.point_areas.point_areas`).
    radii : (n_points,) float64
        Splat radius of each point, ``splat_scale * r_i``, in model units.
    centre : (3,) float64
        Centre of the points' bounding box, where the camera looks.
    diagonal : float
        Diagonal of that box.
    n_points : int
        Number of points.
    """

    def __init__(self, points: ArrayLike, normals: ArrayLike | None = None,
                 camera: Camera | None = None, *, k: int = NEIGHBOURS,
                 splat_scale: float = SPLAT_SCALE, thickness: float = THICKNESS) -> None:
        from vptoolkit.visibility._workspace import morton_order

        own_radii = point_radii(points, k=k)
        cloud = np.asarray(points, dtype=np.float64)
        splat_scale = check_float(splat_scale, "splat_scale", expected="a positive number",
                                  above=0.0)
        thickness = check_float(thickness, "thickness", expected="a number in (0, 1]",
                                above=0.0, maximum=1.0)
        low, high = cloud.min(axis=0), cloud.max(axis=0)
        self.centre = (low + high) / 2.0
        self.diagonal = float(np.linalg.norm(high - low))
        if not self.diagonal > 0.0:
            raise InputError("points: all points coincide, the cloud has no extent")
        self._flatness = 1.0 / thickness**2 - 1.0
        self.camera = camera or Camera()
        self.areas = np.pi * own_radii**2
        self.radii = splat_scale * own_radii
        self.n_points = len(cloud)
        # the rasteriser's Morton order of faces, for points: each point is the centroid of
        # its degenerate face (x + x + x) / 3, rounded as that mean rounds, so the order and
        # with it the z-buffer's ties are those of the faces (x itself would move a few
        # points across a cell's border by one unit in the last place)
        self._order = morton_order((cloud + cloud + cloud) / 3.0)
        self._points = np.ascontiguousarray(cloud[self._order])
        self._radii = np.ascontiguousarray(self.radii[self._order])
        self._workspaces: dict[int, RasterWorkspace] = {}
        if normals is None:
            self._normals = np.zeros((self.n_points, 0))
        else:
            given = np.asarray(normals, dtype=np.float64)
            if given.shape != cloud.shape:
                raise InputError(f"normals: expected shape {cloud.shape}, got {given.shape}")
            lengths = np.linalg.norm(given, axis=1, keepdims=True)
            if not (np.isfinite(given).all() and (lengths > 0.0).all()):
                raise InputError("normals: values must be finite and of non-zero length")
            self._normals = np.ascontiguousarray((given / lengths)[self._order])

    def histograms(self, view_directions: ArrayLike,
                   resolution: int = RESOLUTION) -> Iterator[ViewHistograms]:
        """Yield the per-point pixel histograms of the views, a batch at a time.

        Parameters
        ----------
        view_directions : (n_views, 3) array_like
            Directions from the centre to the camera.
        resolution : int
            Image side in pixels (default: :data:`vptoolkit.conventions.RESOLUTION`).

        Yields
        ------
        ViewHistograms
            Consecutive runs of views covering all of them in order; ``face_ids``
            are point indices, ``n_faces`` the number of points.
        """
        from vptoolkit.visibility._splat import splat_batch
        from vptoolkit.visibility._workspace import RasterWorkspace, histogram_capacity

        resolution = check_int(resolution, "resolution", minimum=1, maximum=MAX_RESOLUTION)
        directions = as_directions(view_directions, name="view_directions")
        poses = self.camera.poses(directions, centre=self.centre, diagonal=self.diagonal,
                                  resolution=resolution)
        workspace = self._workspaces.get(resolution)
        if workspace is None:
            workspace = self._workspaces[resolution] = RasterWorkspace.allocate(
                resolution=resolution, n_faces=self.n_points, n_vertices=0)
        n_threads = workspace.frames.shape[0]
        capacity = histogram_capacity(resolution, self.n_points)
        n_views = len(poses.eyes)
        batch = int(np.clip(_BATCH_BYTES // (8 * capacity), n_threads, 64))
        batch = min(batch - batch % n_threads, max(n_threads, n_views))
        near, far = _depth_range(self.camera, self.diagonal)
        cull = bool(self.camera.cull_back_faces and self._normals.shape[1] == 3)
        out_ids = np.zeros((batch, capacity), dtype=np.int32)
        out_counts = np.zeros((batch, capacity), dtype=np.int32)
        out_lengths = np.zeros(batch, dtype=np.int64)
        for start in range(0, n_views, batch):
            stop = min(start + batch, n_views)
            count = stop - start
            splat_batch(
                self._points, self._radii, self._normals, self._flatness, cull,
                poses.eyes[start:stop], poses.right[start:stop], poses.up[start:stop],
                poses.forward[start:stop], poses.focal_px, resolution, near, far,
                workspace.frames, workspace.row_low, workspace.row_high, workspace.id_counts,
                workspace.touched, out_ids, out_counts, out_lengths,
            )
            lengths = out_lengths[:count]
            local_ids = np.concatenate([out_ids[i, : lengths[i]] for i in range(count)])
            yield ViewHistograms(
                offsets=np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
                face_ids=self._order[local_ids].astype(np.int32),
                pixel_counts=np.concatenate([out_counts[i, : lengths[i]] for i in range(count)]),
                n_faces=self.n_points,
                first_view=start,
            )

    def id_images(self, view_directions: ArrayLike,
                  resolution: int = RESOLUTION) -> NDArray[np.int32]:
        """The point-ID images of the views: which point's splat each pixel shows.

        The splats and z-buffer of :meth:`histograms` (:func:`._splat.splat_ids`),
        so the pixels of point ``i`` in view ``v`` are those it is counted for.

        Parameters
        ----------
        view_directions : (n_views, 3) array_like
            Directions from the centre to the camera.
        resolution : int
            Image side in pixels (default: :data:`vptoolkit.conventions.RESOLUTION`).

        Returns
        -------
        images : (n_views, resolution, resolution) int32
            Index of the point seen through each pixel centre, ``-1`` where no
            splat is; row 0 at the top, column 0 at the left.
        """
        from vptoolkit.visibility._splat import splat_ids

        resolution = check_int(resolution, "resolution", minimum=1, maximum=MAX_RESOLUTION)
        directions = as_directions(view_directions, name="view_directions")
        poses = self.camera.poses(directions, centre=self.centre, diagonal=self.diagonal,
                                  resolution=resolution)
        near, far = _depth_range(self.camera, self.diagonal)
        cull = bool(self.camera.cull_back_faces and self._normals.shape[1] == 3)
        images = np.empty((len(directions), resolution * resolution), dtype=np.int32)
        for view in range(len(directions)):
            splat_ids(self._points, self._radii, self._normals, self._flatness, cull,
                      poses.eyes[view], poses.right[view], poses.up[view], poses.forward[view],
                      poses.focal_px, resolution, near, far, images[view])
        seen = images >= 0
        images[seen] = self._order[images[seen]]
        return images.reshape(len(directions), resolution, resolution)


def iter_point_histograms(
    points: ArrayLike,
    settings: MeasureSettings = MeasureSettings(),
    *,
    normals: ArrayLike | None = None,
    view_directions: ArrayLike | None = None,
) -> Iterator[ViewHistograms]:
    """Yield the per-point pixel histograms of the views of a cloud, a batch at a time.

    The cloud is splatted (:class:`PointScene`, default spacing and splat
    scale) whatever ``settings.backend`` names.

    Parameters
    ----------
    points : (n_points, 3) array_like
        The cloud, in model units.
    settings : MeasureSettings
        The views, image side and camera (default: ``MeasureSettings()``).
    normals : (n_points, 3) array_like, optional
        Outward normals: points facing away from a view are not drawn in it.
    view_directions : (n_views, 3) array_like, optional
        Directions from the centre to the camera, drawn instead of the
        ``settings.views`` Fibonacci-sphere directions.

    Yields
    ------
    ViewHistograms
        As :meth:`PointScene.histograms`.
    """
    settings = check_settings(settings)
    directions = settings.directions() if view_directions is None else view_directions
    scene = PointScene(points, normals, settings.camera)
    yield from scene.histograms(directions, settings.resolution)

