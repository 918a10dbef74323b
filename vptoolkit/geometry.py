"""Basic triangle-mesh geometry: face areas, normals, the bounding frame and the principal frame."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vptoolkit.mesh import Mesh, MeshLike, as_mesh
from vptoolkit.point_cloud import PointCloud

__all__ = [
    "face_cross_products", "face_areas", "face_normals", "bounding_frame", "principal_frame",
    "undirected_edges", "welded_faces",
]


def face_cross_products(mesh: MeshLike) -> NDArray[np.float64]:
    """``(b - a) x (c - a)`` of every triangle ``(a, b, c)``: twice its area times its unit normal.

    Returns
    -------
    cross : (n_faces, 3) float64
        By the right-hand rule on the winding; zero for degenerate faces.
    """
    mesh = as_mesh(mesh)
    vertices, faces = mesh.vertices, mesh.faces
    first = vertices[faces[:, 0]]
    u = vertices[faces[:, 1]] - first
    v = vertices[faces[:, 2]] - first
    # np.cross's own products and differences, without its axis handling
    return np.stack([u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1],
                     u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2],
                     u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]], axis=1)


def face_areas(mesh: MeshLike) -> NDArray[np.float64]:
    """True area of every triangle.

    Returns
    -------
    areas : (n_faces,) float64
        ``|(b - a) x (c - a)| / 2`` in squared model units; 0 for degenerate faces.
    """
    mesh = as_mesh(mesh)
    return 0.5 * np.linalg.norm(face_cross_products(mesh), axis=1)


def face_normals(mesh: MeshLike) -> NDArray[np.float64]:
    """Unit normal of every triangle by the right-hand rule on its winding.

    Returns
    -------
    normals : (n_faces, 3) float64
        ``(b - a) x (c - a)`` normalised; the zero vector for degenerate faces.
    """
    mesh = as_mesh(mesh)
    cross = face_cross_products(mesh)
    length = np.linalg.norm(cross, axis=1, keepdims=True)
    return np.divide(cross, length, out=np.zeros_like(cross), where=length > 0)


def bounding_frame(mesh: MeshLike | PointCloud) -> tuple[NDArray[np.float64], float]:
    """Centre and diagonal of the axis-aligned bounding box of the used vertices.

    Vertices no face refers to are ignored, so stray points in a file do not
    move the camera; a point cloud's box is that of all its points.

    Returns
    -------
    centre : (3,) float64
        Midpoint of the bounding box (the camera's target).
    diagonal : float
        Length of the bounding-box diagonal in model units.
    """
    if isinstance(mesh, PointCloud):
        low, high = mesh.points.min(axis=0), mesh.points.max(axis=0)
        return (low + high) / 2.0, float(np.linalg.norm(high - low))
    mesh = as_mesh(mesh)
    is_used = np.zeros(len(mesh.vertices), dtype=bool)
    is_used[mesh.faces.ravel()] = True
    used = mesh.vertices[is_used]
    low, high = used.min(axis=0), used.max(axis=0)
    return (low + high) / 2.0, float(np.linalg.norm(high - low))


def principal_frame(mesh: Mesh | PointCloud, areas: NDArray[np.float64] | None = None
                    ) -> NDArray[np.float64]:
    """Rows: the surface's principal axes, largest spread first.

    The axes are the eigenvectors of the covariance of the face centroids,
    each weighted by its face's area (``areas``, computed when not given);
    of a point cloud, of its points, each weighted by ``areas`` (the area
    each stands for, :func:`vptoolkit.point_areas.point_areas`; equal
    weights when not given).

    Returns
    -------
    axes : (3, 3) float64
        Orthonormal rows; a right-handed frame.

    Notes
    -----
    Where two spreads are equal (within ``1e-10`` of the largest: a shape
    with a symmetry, such as a corner tetrahedron), any pair of axes of
    their plane would do, and which one the eigensolver returns follows the
    rounding of the covariance, so the mesh's size. There the pair is fixed
    instead: the first is the projection on the plane of the constant
    direction :data:`_REFERENCE`, and the third axis points to its side (the
    eigensolver's sign of it also follows the rounding); three equal spreads
    give the coordinate axes.
    """
    if isinstance(mesh, PointCloud):
        centroids = mesh.points
        areas = np.ones(mesh.n_points) if areas is None else areas
    else:
        areas = face_areas(mesh) if areas is None else areas
        vertices, faces = mesh.vertices, mesh.faces
        centroids = (vertices[faces[:, 0]] + vertices[faces[:, 1]] + vertices[faces[:, 2]]) / 3.0
    total = float(areas.sum())
    weights = areas / total if total > 0 else np.full(len(areas), 1.0 / len(areas))
    centred = centroids - weights @ centroids
    covariance = (centred * weights[:, None]).T @ centred
    spreads, vectors = np.linalg.eigh(covariance)
    spreads, axes = spreads[::-1], vectors[:, ::-1].T.copy()
    tie = _EQUAL_SPREADS * max(float(spreads[0]), 0.0)
    if spreads[0] - spreads[2] <= tie:
        axes = np.eye(3)
    elif spreads[0] - spreads[1] <= tie:  # the two largest are equal: axes[2] is defined
        axes[2] = _signed(axes[2])
        axes[0], axes[1] = _pair_across(axes[2])
    elif spreads[1] - spreads[2] <= tie:  # the two smallest are equal: axes[0] is defined
        axes[0] = _signed(axes[0])
        axes[1], axes[2] = _pair_across(axes[0])
    if np.linalg.det(axes) < 0:
        axes[2] = -axes[2]
    return np.asarray(axes)


_EQUAL_SPREADS = 1e-10
"""Spreads closer than this fraction of the largest count as equal in :func:`principal_frame`."""

_REFERENCE = np.array([0.36, 0.48, 0.8])
"""A unit direction along no symmetry axis of common shapes, fixing the axes of a plane of
equal spreads in :func:`principal_frame`."""


def _signed(axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """``axis`` or its opposite, whichever points to the side of :data:`_REFERENCE`."""
    return -axis if float(axis @ _REFERENCE) < 0 else axis


def _pair_across(normal: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two orthonormal directions across the unit ``normal``: the projection of
    :data:`_REFERENCE` (or of the x axis, when the reference is nearly along ``normal``)
    on the plane, and its cross product with ``normal``."""
    reference = _REFERENCE if abs(float(_REFERENCE @ normal)) < 0.9 else np.array([1.0, 0.0, 0.0])
    first = reference - (reference @ normal) * normal
    first /= np.linalg.norm(first)
    return first, np.cross(normal, first)


def welded_faces(mesh: MeshLike) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The mesh with one vertex per distinct position: ``(vertices, faces)``.

    Faces of a mesh stored as a triangle soup (an STL file) share no vertex
    index; here they share their edges as the surface does.
    """
    mesh = as_mesh(mesh)
    vertices, position = np.unique(mesh.vertices, axis=0, return_inverse=True)
    return vertices, position.reshape(-1)[mesh.faces].astype(np.int64)


def undirected_edges(faces: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Edge id of each face side ``(n_faces, 3)`` and the number of faces on each edge.

    Side ``k`` of face ``f`` joins corners ``k`` and ``k + 1 (mod 3)``; two
    sides share an id when they join the same two vertex indices, in either
    order. Ids run over ``0 .. n_edges - 1`` in increasing order of the
    sorted vertex pair.
    """
    sides = np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1)
    sides = np.sort(sides, axis=2).reshape(-1, 2)
    keys = sides[:, 0] * (int(faces.max()) + 1) + sides[:, 1]
    _, edge_id, counts = np.unique(keys, return_inverse=True, return_counts=True)
    return edge_id.reshape(-1, 3).astype(np.int64), counts.astype(np.int64)
