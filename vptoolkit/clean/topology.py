"""Pure-numpy mesh topology for :mod:`vptoolkit.clean` (no pymeshlab).

Owns the face-array computations the cleaning steps share (undirected edges
come from :func:`vptoolkit.geometry.undirected_edges`): union-find labelling,
the choice of faces to keep on non-manifold edges
(:func:`keep_major_faces_on_non_manifold_edges`), consistently wound patches
(:func:`coherent_patches`), closed components (:func:`closed_components`),
and taking a sub-mesh (:func:`submesh`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vptoolkit.errors import MeasurementError
from vptoolkit.geometry import undirected_edges
from vptoolkit.mesh import Mesh


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
    max_cells: int = 16,
) -> NDArray[np.bool_] | None:
    """Faces whose bounding box, grown by ``margin``, may overlap that of a target face.

    Two triangles can intersect or touch only if their bounding boxes
    overlap, so the result holds every face that can meet a target (the
    targets included), and some more. Boxes are put in the cells of a
    uniform grid sized to the targets (the 90th percentile of their widest
    side); the boxes of a face and a target that share a cell are compared.
    A box spanning
    more than ``max_cells`` cells along an axis is compared with the other
    side's boxes directly. Returns None when that would compare more than
    about ten million pairs (a caller then tests everything).
    """
    corners = vertices[faces]
    low = corners.min(axis=1) - margin
    high = corners.max(axis=1) + margin
    targets = np.flatnonzero(is_target)
    near = is_target.copy()
    if len(targets) == 0:
        return near
    size = float(np.quantile((high[targets] - low[targets]).max(axis=1), 0.9))
    if not size > 0.0:
        return None
    origin = low.min(axis=0)
    first = np.floor((low - origin) / size).astype(np.int64)
    last = np.floor((high - origin) / size).astype(np.int64)
    is_big = ((last - first) >= max_cells).any(axis=1)
    big_targets = targets[is_big[targets]]
    small_targets = targets[~is_big[targets]]
    big_faces = np.flatnonzero(is_big & ~is_target)
    if len(faces) * len(big_targets) + len(big_faces) * len(targets) > 10_000_000:
        return None
    for group, against in ((big_targets, np.arange(len(faces))), (big_faces, targets)):
        # Direct comparison: which boxes of ``against`` overlap a box of ``group``.
        for index in group:
            hit = np.all((low[against] <= high[index]) & (high[against] >= low[index]), axis=1)
            if against is targets:
                near[index] |= bool(hit.any())
            else:
                near[against[hit]] = True
    width = last.max(axis=0) + 1
    if float(np.prod(width.astype(np.float64))) > 2.0**62:
        return None  # cell keys would overflow
    small_faces = np.flatnonzero(~is_big)
    target_owner, target_cells = _cell_keys(first[small_targets], last[small_targets], width)
    order = np.argsort(target_cells, kind="stable")
    target_cells, target_owner = target_cells[order], small_targets[target_owner[order]]
    face_owner, face_cells = _cell_keys(first[small_faces], last[small_faces], width)
    start = np.searchsorted(target_cells, face_cells, side="left")
    counts = np.searchsorted(target_cells, face_cells, side="right") - start
    total = int(counts.sum())
    if total > 10_000_000:
        return None
    # Every (face, target) pair sharing a cell, then the exact box test.
    face = small_faces[np.repeat(face_owner, counts)]
    target = target_owner[np.repeat(start - (np.cumsum(counts) - counts), counts)
                          + np.arange(total)]
    overlap = np.all((low[face] <= high[target]) & (high[face] >= low[target]), axis=1)
    near[face[overlap]] = True
    return near


def _cell_keys(
    first: NDArray[np.int64], last: NDArray[np.int64], width: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Every grid cell of each box ``first..last`` (inclusive): the box's row and the cell's key."""
    counts = last - first + 1
    n_cells = counts.prod(axis=1)
    owner = np.repeat(np.arange(len(first), dtype=np.int64), n_cells)
    # Position of each cell within its box, unravelled over the box's own counts.
    local = np.arange(int(n_cells.sum()), dtype=np.int64) - np.repeat(
        np.cumsum(n_cells) - n_cells, n_cells)
    count = counts[owner]
    x = first[owner, 0] + local % count[:, 0]
    y = first[owner, 1] + (local // count[:, 0]) % count[:, 1]
    z = first[owner, 2] + local // (count[:, 0] * count[:, 1])
    return owner, (z * width[1] + y) * width[0] + x
