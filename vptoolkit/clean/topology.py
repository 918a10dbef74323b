"""Pure-numpy mesh topology for :mod:`vptoolkit.clean` (no pymeshlab).

Owns the face-array computations the cleaning steps share: undirected edges
and how many faces each has (:func:`undirected_edges`), union-find labelling,
the choice of faces to keep on non-manifold edges
(:func:`keep_major_faces_on_non_manifold_edges`), consistently wound patches
(:func:`coherent_patches`), closed components (:func:`closed_components`),
taking a sub-mesh (:func:`submesh`) and the mesh argument check
(:func:`check_mesh`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.mesh import Mesh


def check_mesh(mesh: Mesh) -> None:
    if not isinstance(mesh, Mesh):
        raise InputError(f"mesh: expected a vptoolkit Mesh, got {type(mesh).__name__}")


def undirected_edges(faces: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Edge id of each face side ``(n_faces, 3)`` and the number of faces on each edge."""
    sides = np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1)
    sides = np.sort(sides, axis=2).reshape(-1, 2)
    keys = sides[:, 0] * (int(faces.max()) + 1) + sides[:, 1]
    _, edge_id, counts = np.unique(keys, return_inverse=True, return_counts=True)
    return edge_id.reshape(-1, 3).astype(np.int64), counts.astype(np.int64)


def _union_find(
    n_items: int, first: NDArray[np.int64], second: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Component label ``0 .. k-1`` of each item joined by the pairs (hook and pointer-jump)."""
    parent = np.arange(n_items, dtype=np.int64)
    while len(first):
        root_first, root_second = parent[first], parent[second]
        differ = root_first != root_second
        if not differ.any():
            break
        low = np.minimum(root_first[differ], root_second[differ])
        high = np.maximum(root_first[differ], root_second[differ])
        np.minimum.at(parent, high, low)
        while True:
            grand = parent[parent]
            if np.array_equal(grand, parent):
                break
            parent = grand
    return np.unique(parent, return_inverse=True)[1].astype(np.int64).reshape(-1)


def keep_major_faces_on_non_manifold_edges(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> NDArray[np.bool_]:
    """On each edge with more than two faces, keep the two from the largest patches."""
    edge_id, counts = undirected_edges(faces)
    keep = np.ones(len(faces), dtype=bool)
    if not (counts > 2).any():
        return keep
    # Patches: faces joined through manifold edges (exactly two faces).
    flat_edges = edge_id.ravel()
    flat_faces = np.repeat(np.arange(len(faces), dtype=np.int64), 3)
    manifold = counts[flat_edges] == 2
    order = np.argsort(flat_edges[manifold], kind="stable")
    paired = flat_faces[manifold][order].reshape(-1, 2)
    patch = _union_find(len(faces), paired[:, 0], paired[:, 1])
    corners = vertices[faces]
    areas = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    patch_area = np.bincount(patch, weights=areas)
    # Faces on each non-manifold edge, largest patch first (then larger face).
    crowded = counts[flat_edges] > 2
    edges, on_faces = flat_edges[crowded], flat_faces[crowded]
    order = np.lexsort((-areas[on_faces], -patch_area[patch[on_faces]], edges))
    edges, on_faces = edges[order], on_faces[order]
    rank = np.arange(len(edges)) - np.searchsorted(edges, edges, side="left")
    keep[on_faces[rank >= 2]] = False
    return keep


def coherent_patches(faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """Label faces joined through manifold edges that they traverse in opposite directions."""
    sides = np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1).reshape(-1, 2)
    is_forward = sides[:, 0] < sides[:, 1]
    edge_id, counts = undirected_edges(faces)
    flat_edges = edge_id.ravel()
    flat_faces = np.repeat(np.arange(len(faces), dtype=np.int64), 3)
    manifold = counts[flat_edges] == 2
    order = np.argsort(flat_edges[manifold], kind="stable")
    paired_faces = flat_faces[manifold][order].reshape(-1, 2)
    paired_forward = is_forward[manifold][order].reshape(-1, 2)
    coherent = paired_forward[:, 0] != paired_forward[:, 1]
    return _union_find(len(faces), paired_faces[coherent, 0], paired_faces[coherent, 1])


def closed_components(
    faces: NDArray[np.int64], n_vertices: int
) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Component of each face, and whether each component is closed and consistently oriented."""
    first = faces.ravel()
    second = np.roll(faces, -1, axis=1).ravel()
    label = _union_find(n_vertices, first, second)[faces[:, 0]]
    n_components = int(label.max()) + 1
    key_width = n_vertices
    forward = first * key_width + second
    backward = second * key_width + first
    unique, counts = np.unique(forward, return_counts=True)
    position = np.clip(np.searchsorted(unique, backward), 0, len(unique) - 1)
    has_twin = unique[position] == backward
    is_good = has_twin & (counts[np.searchsorted(unique, forward)] == 1)
    is_good &= np.where(has_twin, counts[position] == 1, False)
    face_good = is_good.reshape(-1, 3).all(axis=1)
    bad_count = np.bincount(label, weights=~face_good, minlength=n_components)
    return label, bad_count == 0


def submesh(
    mesh: Mesh, keep: NDArray[np.bool_], step: str, *, flip: NDArray[np.bool_] | None = None
) -> Mesh:
    """The kept faces (reversed where ``flip``) without unreferenced vertices."""
    if not keep.any():
        raise MeasurementError(f"{mesh.name}: cleaning step {step!r} left no faces")
    faces = mesh.faces.copy()
    if flip is not None:
        faces[flip] = faces[flip][:, ::-1]
    faces = faces[keep]
    used = np.unique(faces)
    remap = np.zeros(mesh.n_vertices, dtype=np.int64)
    remap[used] = np.arange(len(used), dtype=np.int64)
    return Mesh(mesh.vertices[used], remap[faces], name=mesh.name)


def faces_near(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    is_target: NDArray[np.bool_],
    margin: float,
    *,
    max_pairs: int = 5_000_000,
) -> NDArray[np.bool_] | None:
    """Faces whose bounding box, grown by ``margin``, may overlap that of a target face.

    Two triangles can intersect or touch only if their bounding boxes
    overlap, so the result holds every face that can meet a target (the
    targets included). Boxes are paired by sorting along the axis that gives
    the fewest pairs; the 5 % of faces widest along it are kept without
    comparing. Returns None when more than ``max_pairs`` pairs would be
    compared (a caller then tests everything).
    """
    corners = vertices[faces]
    low = corners.min(axis=1) - margin
    high = corners.max(axis=1) + margin
    near = is_target.copy()
    targets = np.flatnonzero(is_target)
    if len(targets) == 0:
        return near
    best = None
    for axis in range(3):
        width = high[:, axis] - low[:, axis]
        limit = float(np.quantile(width, 0.95))
        order = np.argsort(low[:, axis], kind="stable")
        sorted_low = low[order, axis]
        # A face no wider than ``limit`` overlaps target t along this axis only
        # if its low end lies in [low_t - limit, high_t].
        start = np.searchsorted(sorted_low, low[targets, axis] - limit, side="left")
        stop = np.searchsorted(sorted_low, high[targets, axis], side="right")
        total = int((stop - start).sum())
        if best is None or total < best[0]:
            best = (total, width > limit, order, start, stop)
    total, is_wide, order, start, stop = best
    if total > max_pairs:
        return None
    near |= is_wide
    counts = stop - start
    first = np.repeat(start - (np.cumsum(counts) - counts), counts)
    other = order[first + np.arange(total)]
    target = np.repeat(targets, counts)
    overlap = np.all((low[other] <= high[target]) & (high[other] >= low[target]), axis=1)
    near[other[overlap]] = True
    return near
