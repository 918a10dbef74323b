"""Reference backend: Open3D's ``RaycastingScene`` (Embree), one ray per pixel.

Slow (tens of milliseconds per 1024 x 1024 view) but independent of the
rasteriser, so tests hold the two against each other. Back-face culling is
done by casting again from just behind every hit on a back face (or on a
zero-area face) until each ray meets a front face or leaves the scene.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.camera import ViewPoses
from vptoolkit.errors import MeasurementError
from vptoolkit.optional import require

if TYPE_CHECKING:
    from vptoolkit.mesh import Mesh

_MAX_PEELS = 256


class RaycastScene:
    """An Open3D ray-casting scene of one mesh with its face planes."""

    def __init__(self, mesh: Mesh, *, face_normals: NDArray[np.float64],
                 face_offsets: NDArray[np.float64], is_drawable: NDArray[np.bool_],
                 diagonal: float) -> None:
        o3d = require("open3d", extra="measures")
        self._o3d: Any = o3d
        self._scene = o3d.t.geometry.RaycastingScene()
        self._scene.add_triangles(
            o3d.core.Tensor(mesh.vertices.astype(np.float32)),
            o3d.core.Tensor(mesh.faces.astype(np.uint32)),
        )
        self._normals = face_normals
        self._offsets = face_offsets
        self._is_drawable = is_drawable
        self._epsilon = 1e-6 * diagonal
        self._invalid = int(self._scene.INVALID_ID)

    def face_ids(self, poses: ViewPoses, view: int, *, cull_back_faces: bool) -> NDArray[np.int64]:
        """Visible face per pixel of one view, -1 for background.

        Returns
        -------
        face_ids : (resolution * resolution,) int64
            Row-major, pixel ``(x, y)`` at ``y * resolution + x``.
        """
        rays = poses.pixel_rays(view)
        eye = poses.eyes[view]
        if cull_back_faces:
            is_visible_face = self._is_drawable & (self._normals @ eye > self._offsets)
        else:
            is_visible_face = self._is_drawable
        result = np.full(len(rays), -1, dtype=np.int64)
        pending = np.arange(len(rays))
        for _ in range(_MAX_PEELS):
            hits = self._scene.cast_rays(self._o3d.core.Tensor(rays[pending]))
            ids = hits["primitive_ids"].numpy().astype(np.int64)
            t_hit = hits["t_hit"].numpy()
            is_hit = ids != self._invalid
            is_accepted = is_hit.copy()
            is_accepted[is_hit] = is_visible_face[ids[is_hit]]
            result[pending[is_accepted]] = ids[is_accepted]
            is_peeled = is_hit & ~is_accepted
            if not is_peeled.any():
                return result
            pending = pending[is_peeled]
            advance = (t_hit[is_peeled] + self._epsilon).astype(np.float32)
            rays[pending, :3] += rays[pending, 3:] * advance[:, None]
        raise MeasurementError(
            f"ray casting: rays still hit back faces after {_MAX_PEELS} layers in view {view}"
        )

    def depths(self, poses: ViewPoses, view: int,
               face_ids: NDArray[np.int64]) -> NDArray[np.float64]:
        """Distance along the camera axis to the seen face of each pixel of one view.

        The ray through the centre of pixel ``(x, y)`` is ``eye + z D`` with
        ``D = forward + u right - v up``, ``u = (x + 1/2 - res/2) / f`` and
        ``v = (y + 1/2 - res/2) / f``; it meets the plane ``n . p = offset``
        of its face at ``z = (offset - n . eye) / (n . D)``, in double
        precision whatever the float32 hit distance of the cast.

        Parameters
        ----------
        face_ids : (resolution * resolution,) int64
            :meth:`face_ids` of the view.

        Returns
        -------
        depths : (resolution * resolution,) float64
            ``z`` per pixel, row-major; NaN where no face is seen.
        """
        res = poses.resolution
        tangents = (np.arange(res) + 0.5 - res / 2.0) / poses.focal_px
        seen = np.flatnonzero(face_ids >= 0)
        faces = face_ids[seen]
        normals = self._normals[faces]
        across = tangents[seen % res] * (normals @ poses.right[view])
        down = tangents[seen // res] * (normals @ poses.up[view])
        depths = np.full(len(face_ids), np.nan)
        depths[seen] = ((self._offsets[faces] - normals @ poses.eyes[view])
                        / (normals @ poses.forward[view] + across - down))
        return depths
