"""Reference backend: Open3D's ``RaycastingScene`` (Embree), one ray per pixel.

Slow (tens of milliseconds per 1024 x 1024 view) but independent of the
rasteriser, so tests hold the two against each other.

Each pixel sees the nearest face, along the ray through its centre, among the
faces the view draws: those of non-zero area that face the eye (``n . eye >
offset`` for the face plane ``n . x = offset``), or all those of non-zero
area without back-face culling. Every ray is cast first against the whole
mesh (one scene, built once); a ray whose first hit is a face the view does
not draw is cast again, from the eye, against a scene of only the faces the
view draws, built for that view. Casting on from just behind the culled hit
instead would skip the drawn faces at the same distance: a front face in the
plane of a reversed copy of itself (``bunny.ply`` holds 81), or the front
face across a silhouette edge from the back face that the ray met on that
edge. The second scene is built only for views where some ray meets a culled
face first: seldom on a closed mesh seen from outside, in most views of a
mesh with holes or faces held twice (milliseconds per ten thousand faces).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.camera import ViewPoses
from vptoolkit.optional import require

if TYPE_CHECKING:
    from vptoolkit.mesh import Mesh


class RaycastScene:
    """Open3D ray-casting scenes of one mesh, with its face planes.

    Parameters
    ----------
    mesh : Mesh
        The model.
    face_normals : (n_faces, 3) float64
        Normals ``n`` of the face planes ``n . x = offset``, of any length
        (zero for a face of zero area).
    face_offsets : (n_faces,) float64
        Their offsets.
    is_drawable : (n_faces,) bool
        Faces that can be seen at all (non-zero area).
    """

    def __init__(self, mesh: Mesh, *, face_normals: NDArray[np.float64],
                 face_offsets: NDArray[np.float64], is_drawable: NDArray[np.bool_]) -> None:
        o3d = require("open3d", extra="measures")
        self._o3d: Any = o3d
        self._vertices = o3d.core.Tensor(mesh.vertices.astype(np.float32))
        self._faces = mesh.faces.astype(np.uint32)
        self._scene = self._build(self._faces)
        self._normals = face_normals
        self._offsets = face_offsets
        self._is_drawable = is_drawable

    def _build(self, faces: NDArray[np.uint32]) -> Any:
        """A scene of these triangles of the mesh (primitive ``i`` is ``faces[i]``)."""
        scene = self._o3d.t.geometry.RaycastingScene()
        scene.add_triangles(self._vertices, self._o3d.core.Tensor(faces))
        return scene

    def _first_hits(self, scene: Any, rays: NDArray[np.float32]) -> NDArray[np.int64]:
        """Primitive of ``scene`` that each ray meets first, -1 where it meets none."""
        ids = scene.cast_rays(self._o3d.core.Tensor(rays))["primitive_ids"].numpy()
        return np.where(ids == scene.INVALID_ID, -1, ids.astype(np.int64))

    def face_ids(self, poses: ViewPoses, view: int, *, cull_back_faces: bool) -> NDArray[np.int64]:
        """Visible face per pixel of one view, -1 for background.

        Returns
        -------
        face_ids : (resolution * resolution,) int64
            Row-major, pixel ``(x, y)`` at ``y * resolution + x``: the nearest
            face the view draws along the ray through the pixel centre.
        """
        rays = poses.pixel_rays(view)
        is_drawn = self._is_drawable
        if cull_back_faces:
            is_drawn = is_drawn & (self._normals @ poses.eyes[view] > self._offsets)
        result = self._first_hits(self._scene, rays)
        is_hit = result >= 0
        is_culled = is_hit.copy()
        is_culled[is_hit] = ~is_drawn[result[is_hit]]
        blocked = np.flatnonzero(is_culled)
        if len(blocked) == 0:
            return result
        drawn = np.flatnonzero(is_drawn)
        result[blocked] = -1
        if len(drawn) > 0:
            hits = self._first_hits(self._build(self._faces[drawn]), rays[blocked])
            result[blocked[hits >= 0]] = drawn[hits[hits >= 0]]
        return result

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
