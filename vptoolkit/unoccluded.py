"""View quality with occlusion ignored: a closed-form estimate from surface normals.

A surface of elements ``z`` (mesh faces, or surface points standing for equal
shares of the area) with areas ``A_z`` and unit outward normals ``n_z``
projects, seen orthographically from direction ``d`` with nothing hiding
anything, an area

    a_z(d) = A_z max(0, n_z . d),    a_t(d) = sum_z a_z(d).

Putting these in place of the pixel counts of :mod:`vptoolkit.measures` gives,
in bits, with ``p_z = a_z / a_t`` and ``A_t = sum_z A_z``:

* VE(d)  = -sum_z p_z log2 p_z (higher is better);
* VR(d)  ~ a_t(d) / A_t, the projected share of the surface: with occlusion
  ignored the visible share of a closed surface is always about a half, so its
  projection stands in for it (higher is better);
* VKL(d) = sum_z p_z log2(p_z A_t / A_z) (lower is better);
* VMI(d) = VKL(d): ``p(z)``, the share of ``z`` over the whole sphere, is
  ``A_z / A_t`` when nothing is hidden, because the mean of
  ``max(0, n . d)`` over uniform ``d`` is 1/4 for every ``n``.

The estimate needs one ``(elements x directions)`` product, no image: it is
the zero-view answer of :func:`unoccluded_best_views` (points with normals
suffice, so a scan without a mesh has one) and the candidate proposer of
:class:`UnoccludedPrior` for :func:`vptoolkit.best_view.search_best_views`.
It is exact for a convex surface and misleads where parts hide each other.

Directions are unit vectors from the model's centre towards the camera, in the
model's own coordinates. Numpy only.
"""

from __future__ import annotations

from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.conventions import HIGHER_IS_BETTER, MEASURES
from vptoolkit.errors import InputError
from vptoolkit.geometry import face_areas, face_normals
from vptoolkit.mesh import Mesh
from vptoolkit.sphere import as_directions, distinct_directions

__all__ = [
    "UNOCCLUDED_DIRECTIONS",
    "UnoccludedPrior",
    "mesh_elements",
    "unoccluded_best_views",
    "unoccluded_quality",
]

UNOCCLUDED_DIRECTIONS: Final = 128
"""Default number of directions the estimate is evaluated at (about 18 degrees apart)."""

_CHUNK_ENTRIES = 1 << 22  # elements x directions per block of the product (16 MiB of float32)
_TINY = np.finfo(np.float32).tiny
_RANKED = 32  # best directions per measure looked through for distinct candidates


def mesh_elements(mesh: Mesh) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit normals and areas of the faces of positive area, wound outwards.

    A mesh whose signed volume ``sum_z A_z (c_z . n_z) / 3`` (``c_z`` the face
    centroid) is negative is wound inside out; its normals are flipped.

    Returns
    -------
    normals : (k, 3) float64, areas : (k,) float64
    """
    areas = face_areas(mesh)
    keep = areas > 0
    if not keep.any():
        raise InputError(f"{mesh.name}: the mesh has zero surface area")
    normals = face_normals(mesh)[keep]
    areas = areas[keep]
    corners = mesh.vertices[mesh.faces[keep]]
    centroids = corners.mean(axis=1) - corners.reshape(-1, 3).mean(axis=0)
    if float(np.sum(areas * np.einsum("ij,ij->i", centroids, normals))) < 0.0:
        normals = -normals
    return normals, areas


def unoccluded_quality(normals: ArrayLike, areas: ArrayLike,
                       directions: ArrayLike) -> NDArray[np.float64]:
    """Raw VE, VR, VKL and VMI with occlusion ignored (module docstring).

    Parameters
    ----------
    normals : (k, 3) array_like
        Unit outward normals of the surface elements.
    areas : (k,) array_like
        Their areas (any common unit; equal for a uniform point sample).
    directions : (n, 3) array_like
        Unit view directions.

    Returns
    -------
    raw : (n, 4) float64
        In ``MEASURES`` order; NaN where no element faces the direction.
    """
    normals = np.asarray(normals, dtype=np.float64)
    areas = np.asarray(areas, dtype=np.float64)
    directions = as_directions(directions)
    if normals.ndim != 2 or normals.shape[1] != 3 or areas.shape != normals.shape[:1]:
        raise InputError(f"normals, areas: expected shapes (k, 3) and (k,), "
                         f"got {normals.shape} and {areas.shape}")
    if not (np.isfinite(normals).all() and np.isfinite(areas).all()) or (areas < 0).any():
        raise InputError("normals, areas: expected finite values and areas >= 0")
    total = float(areas.sum())
    if not total > 0.0:
        raise InputError("areas: the surface has zero area")
    share = areas / total
    log_share = np.log2(share, out=np.zeros_like(share), where=share > 0)
    normals32, share32 = normals.astype(np.float32), share.astype(np.float32)
    raw = np.full((len(directions), len(MEASURES)), np.nan)
    step = max(1, _CHUNK_ENTRIES // max(1, len(areas)))
    for start in range(0, len(directions), step):
        block = directions[start:start + step]
        # a_z(d) / A_t in float32, with its sums in float64: ranks, not bits, are what count
        projected = normals32 @ block.T.astype(np.float32)
        np.maximum(projected, 0.0, out=projected)
        projected *= share32[:, None]
        log_projected = np.log2(np.maximum(projected, _TINY))  # 0 log 0 = 0 in the sums below
        a_t = projected.sum(axis=0, dtype=np.float64)
        seen = a_t > 0
        a_t_seen = np.where(seen, a_t, 1.0)
        sum_a_log_a = np.einsum("zd,zd->d", projected, log_projected, dtype=np.float64)
        sum_p_log_p = sum_a_log_a / a_t_seen - np.log2(a_t_seen)
        kl = sum_p_log_p - (log_share.astype(np.float32) @ projected).astype(np.float64) / a_t_seen
        rows = np.stack([-sum_p_log_p, a_t, kl, kl], axis=1)
        raw[start:start + step] = np.where(seen[:, None], rows, np.nan)
    return raw


def _ranked(raw: NDArray[np.float64], column: int) -> NDArray[np.intp]:
    """Direction indices from best to worst for one measure, NaN last (stable order)."""
    values = raw[:, column] if HIGHER_IS_BETTER[column] else -raw[:, column]
    return np.argsort(-np.where(np.isfinite(values), values, -np.inf), kind="stable")


def unoccluded_best_views(normals: ArrayLike, areas: ArrayLike | None = None, *,
                          directions: ArrayLike | int = UNOCCLUDED_DIRECTIONS,
                          ) -> NDArray[np.float64]:
    """The best direction per measure of the occlusion-free estimate: no image drawn.

    Parameters
    ----------
    normals : (k, 3) array_like
        Unit outward normals: of a mesh's faces (:func:`mesh_elements`) or of
        a uniform surface sample such as a scan's points.
    areas : (k,) array_like, optional
        Element areas (default: equal, as for a uniform point sample).
    directions : (n, 3) array_like or int
        Directions to choose from, or how many Fibonacci directions
        (:func:`vptoolkit.sphere.fibonacci_sphere`) (default: 128).

    Returns
    -------
    directions : (4, 3) float64
        Best unit direction per measure in ``MEASURES`` order (VMI's equals VKL's).

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box(extents=(1, 2, 4))
    >>> normals, areas = mesh_elements(Mesh(box.vertices, box.faces))
    >>> unoccluded_best_views(normals, areas).shape
    (4, 3)
    """
    from vptoolkit.sphere import fibonacci_sphere

    normals = np.asarray(normals, dtype=np.float64)
    if isinstance(directions, (int, np.integer)) and not isinstance(directions, bool):
        candidates = fibonacci_sphere(int(directions))
    else:
        candidates = as_directions(directions)
    weights = np.ones(len(normals)) if areas is None else areas
    raw = unoccluded_quality(normals, weights, candidates)
    return np.stack([candidates[_ranked(raw, column)[0]] for column in range(len(MEASURES))])


class UnoccludedPrior:
    """Candidate directions of a mesh from the occlusion-free estimate, for the search.

    The estimate is evaluated on ``n_directions`` directions of the mesh's
    principal-frame Fibonacci sphere (:func:`vptoolkit.best_view.coarse_directions`,
    so it turns with the mesh); the candidates are each of VE, VR and VKL's
    best ``per_measure`` directions at least ``min_angle_deg`` apart, rank by
    rank in ``MEASURES`` order (VMI's estimate is VKL's), duplicates dropped.
    No image is drawn; the cost is one ``(faces x n_directions)`` product.

    Parameters
    ----------
    n_directions : int
        Directions evaluated (default: 128).
    per_measure : int
        Candidates per measure (default: 2).
    min_angle_deg : float
        Smallest angle between two candidates of one measure (default: 30).

    Examples
    --------
    >>> search_best_views(mesh, 16, prior=UnoccludedPrior()(mesh))   # doctest: +SKIP
    """

    def __init__(self, n_directions: int = UNOCCLUDED_DIRECTIONS, *, per_measure: int = 2,
                 min_angle_deg: float = 30.0) -> None:
        for name, value in (("n_directions", n_directions), ("per_measure", per_measure)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise InputError(f"{name}: expected a positive integer, got {value!r}")
        if not 0.0 <= float(min_angle_deg) < 180.0:
            raise InputError(f"min_angle_deg: expected an angle in [0, 180), got {min_angle_deg!r}")
        self.n_directions = int(n_directions)
        self.per_measure = int(per_measure)
        self.min_angle_deg = float(min_angle_deg)

    def __call__(self, mesh: Mesh) -> NDArray[np.float64]:
        """Candidate unit directions ``(k, 3)``, most promising first."""
        from vptoolkit.best_view import coarse_directions

        normals, areas = mesh_elements(mesh)
        directions = coarse_directions(mesh, self.n_directions)
        raw = unoccluded_quality(normals, areas, directions)
        measures = [MEASURES.index(name) for name in ("VE", "VR", "VKL")]
        per_measure = [distinct_directions(directions[_ranked(raw, column)[:_RANKED]],
                                           self.min_angle_deg)[:self.per_measure]
                       for column in measures]
        ranked = [found[rank] for rank in range(self.per_measure)
                  for found in per_measure if rank < len(found)]
        return distinct_directions(np.array(ranked).reshape(-1, 3), 1.0)
