"""Per-face mean curvature of a triangle mesh, from the dihedral angles of its edges.

The discretisation is the edge-based one of a polyhedral surface: all of its
curvature sits on the edges, and an edge ``e`` of length ``|e|`` whose two
faces turn by the signed dihedral angle ``theta_e`` (the angle between their
normals; positive where the surface is convex, i.e. bends away from its
outward normals, negative where concave) carries the integrated mean
curvature

``integral of H dA over e = |e| theta_e / 2``,

with ``H = (k1 + k2) / 2``. (A cylinder of radius ``r`` and length ``L``
drawn as a prism of ``n`` sides: ``n * L (2 pi / n) / 2 = pi L``, exactly
``(1 / 2r) * 2 pi r L``.) An edge's integral is spread over the area its two
faces lend it, ``A_e = (A_1 + A_2) / 3`` (each face lends a third of its area
to each of its edges), which gives a density per edge, and a face's mean
curvature is the mean of the densities of its three edges:

``H_e = |e| theta_e / (2 A_e)``,  ``H_f = (H_e1 + H_e2 + H_e3) / 3``.

Then ``sum_f A_f H_f = sum_e |e| theta_e / 2``: the faces hold exactly the
surface's integrated mean curvature. A face of a sphere of radius ``r``
gets ``H_f`` close to ``1 / r``, a flat region 0, and a triangle of a unit
cube split along its square's diagonal ``pi / 2`` (two 90-degree cube edges
of density ``3 pi / 4`` and a flat diagonal).

Conventions
    Vertices at the same position are one vertex, so a triangle soup (as
    STL files store meshes) gets the curvature of the surface it draws.
    Units are inverse model units. Signs follow the winding: faces
    counter-clockwise seen from the front (:class:`vptoolkit.mesh.Mesh`), so
    a closed, outward-wound convex mesh has ``H_f >= 0``. An edge counts as
    flat (``theta_e = 0``) where it has no defined dihedral angle: a boundary
    edge (one face), a non-manifold edge (three faces or more), an edge whose
    two faces are wound inconsistently (both run it in the same direction),
    an edge whose two faces lie back to back (a zero-thickness fold, which
    bends neither outward nor inward) and an edge of a degenerate
    (zero-area) face. A degenerate face gets 0.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from vptoolkit.geometry import face_cross_products, undirected_edges, welded_faces
from vptoolkit.io import require_surface
from vptoolkit.mesh import MeshLike, as_mesh

if TYPE_CHECKING:
    from vptoolkit.measures.data import ViewData

__all__ = ["CACHE_KEY", "face_mean_curvature", "mesh_curvature"]

CACHE_KEY = "curvature"
"""Key of the per-face mean curvature in :attr:`ViewData.cache`."""

_COPLANAR = 1e-12
"""Far corners nearer the other face's plane than this fraction of their reach lie in it."""


def face_mean_curvature(mesh: MeshLike) -> NDArray[np.float64]:
    """Mean curvature of every face from the dihedral angles of its edges.

    Parameters
    ----------
    mesh : MeshLike
        The model.

    Returns
    -------
    curvature : (n_faces,) float64
        ``H_f``, in inverse model units, positive where convex; the
        discretisation and which edges count as flat are in the module
        docstring.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
    >>> bool(np.allclose(face_mean_curvature(box), np.pi / 4))
    True
    """
    mesh = as_mesh(mesh)
    # One index per position, so the faces of a triangle soup share their edges.
    vertices, faces = welded_faces(mesh)
    n_faces = len(faces)
    cross = face_cross_products(mesh)
    double_areas = np.linalg.norm(cross, axis=1)
    normals = np.divide(cross, double_areas[:, None], out=np.zeros_like(cross),
                        where=double_areas[:, None] > 0)

    # Half-edges: corner k of face f runs from faces[f, k] to faces[f, k + 1].
    starts = faces.ravel()
    ends = np.roll(faces, -1, axis=1).ravel()
    opposite = np.roll(faces, -2, axis=1).ravel()
    owner = np.repeat(np.arange(n_faces, dtype=np.int64), 3)
    keys = undirected_edges(faces)[0].ravel()
    order = np.argsort(keys, kind="stable")
    _, first, count = np.unique(keys[order], return_index=True, return_counts=True)
    pair = first[count == 2]
    one, two = order[pair], order[pair + 1]

    face_one, face_two = owner[one], owner[two]
    is_bent = (starts[one] == ends[two]) & (double_areas[face_one] > 0) \
        & (double_areas[face_two] > 0)
    one, two, face_one, face_two = one[is_bent], two[is_bent], face_one[is_bent], face_two[is_bent]
    normal_one, normal_two = normals[face_one], normals[face_two]
    sine = np.linalg.norm(np.cross(normal_one, normal_two), axis=1)
    cosine = np.einsum("ij,ij->i", normal_one, normal_two)
    # Convex where the far corner of each face lies behind the other face's plane; where
    # both lie in it up to rounding the faces are coplanar, or back to back with no sign.
    base = vertices[starts[one]]
    far_one, far_two = vertices[opposite[one]] - base, vertices[opposite[two]] - base
    behind = np.einsum("ij,ij->i", normal_one, far_two) + np.einsum("ij,ij->i", normal_two, far_one)
    reach = np.linalg.norm(far_one, axis=1) + np.linalg.norm(far_two, axis=1)
    sign = np.where(np.abs(behind) <= _COPLANAR * reach, 0.0, -np.sign(behind))
    dihedral = sign * np.arctan2(sine, cosine)
    lengths = np.linalg.norm(vertices[ends[one]] - base, axis=1)
    shared_area = (double_areas[face_one] + double_areas[face_two]) / 6.0
    density = lengths * dihedral / (2.0 * shared_area)

    curvature = np.bincount(face_one, weights=density, minlength=n_faces)
    curvature += np.bincount(face_two, weights=density, minlength=n_faces)
    return curvature / 3.0


def mesh_curvature(data: ViewData) -> NDArray[np.float64]:
    """:func:`face_mean_curvature` of ``data.mesh``, computed once per :class:`ViewData`.

    Kept in ``data.mesh_cache`` under :data:`CACHE_KEY` for every measure that
    reads it.

    Returns
    -------
    curvature : (n_faces,) float64
        ``H_f`` in inverse model units.
    """
    if CACHE_KEY not in data.mesh_cache:
        data.mesh_cache[CACHE_KEY] = face_mean_curvature(require_surface(data.mesh))
    curvature: NDArray[np.float64] = data.mesh_cache[CACHE_KEY]
    return curvature
