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

With ``W_z = A_z`` and ``c_z(d) = max(0, n_z . d)`` these are

    VE  = log2 a_t - (sum_z c_z A_z log2 A_z + sum_z W_z c_z log2 c_z) / a_t,
    VKL = (sum_z W_z c_z log2 c_z) / a_t - log2 a_t + log2 A_t,

so the elements enter only through their normals, ``W_z`` and ``A_z log2 A_z``,
and elements of nearly the same normal can be pooled: by default they are
summed per cell of a ``32 x 32`` octahedral grid of normals (cells of about 6
degrees; :data:`NORMAL_CELLS`), each cell at its area-weighted mean normal,
which turns a million faces into at most 1024 terms. ``cells=None`` keeps
every element.

The estimate needs no image: it is the zero-view answer of
:func:`unoccluded_best_views` (points with normals suffice, so a scan without a
mesh has one), the prior :class:`vptoolkit.best_view.prior.UnoccludedPrior` of
the best-view search and the predictor ``"unoccluded"`` of
:func:`vptoolkit.predictors.resolve_predictor`. It is exact for a convex surface
seen from afar (orthographically) and misleads where parts hide each other.
Only these four measures have a closed form here (:data:`UNOCCLUDED_MEASURES`);
:func:`unoccluded_measures` refuses any other registered name in one line.

Directions are unit vectors from the model's centre towards the camera, in the
model's own coordinates. Numpy only.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.errors import InputError
from vptoolkit.geometry import face_cross_products
from vptoolkit.measures.quality import ranked_views
from vptoolkit.measures.registry import resolve_measures
from vptoolkit.mesh import Mesh, MeshLike, as_mesh
from vptoolkit.point_areas import point_areas
from vptoolkit.point_cloud import PointCloud
from vptoolkit.sphere import as_directions, fibonacci_sphere

__all__ = [
    "NORMAL_CELLS",
    "UNOCCLUDED_DIRECTIONS",
    "UNOCCLUDED_MEASURES",
    "cloud_elements",
    "face_elements",
    "mesh_elements",
    "unit_normals",
    "unoccluded_best_views",
    "unoccluded_measures",
    "unoccluded_quality",
]

UNOCCLUDED_DIRECTIONS: Final = 128
"""Default number of directions the estimate is evaluated at (about 18 degrees apart)."""

NORMAL_CELLS: Final = 32
"""Side of the octahedral grid the elements' normals are pooled on (1024 cells)."""

UNOCCLUDED_MEASURES: Final = ("VE", "VR", "VKL", "VMI")
"""The measures the estimate has a closed form for, in the column order of
:func:`unoccluded_quality` (the paper's four)."""

_CHUNK_ENTRIES = 1 << 21  # elements x directions per block of the product (16 MiB of float64)
_TINY = np.finfo(np.float64).tiny


def unoccluded_measures(measures: str | Iterable[str] | None = None) -> tuple[str, ...]:
    """The measure names of ``measures`` the estimate answers, in the order given.

    Parameters
    ----------
    measures : str, iterable of str or None
        Registered names, ``"paper"`` or ``"all"``
        (:func:`vptoolkit.measures.registry.resolve_measures`; default: the
        paper's four).

    Raises
    ------
    InputError
        For an unknown name, or in one line for a registered measure without
        a closed form, e.g. ``measures: the unoccluded estimate has no closed
        form for SL, MD (it needs the drawn image); it estimates VE, VR, VKL,
        VMI``.
    """
    names = resolve_measures(measures)
    missing = [name for name in names if name not in UNOCCLUDED_MEASURES]
    if missing:
        raise InputError(f"measures: the unoccluded estimate has no closed form for "
                         f"{', '.join(missing)} (it needs the drawn image); it estimates "
                         f"{', '.join(UNOCCLUDED_MEASURES)}")
    return names


def mesh_elements(mesh: MeshLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit normals and areas of the faces of positive area, wound outwards.

    A mesh whose signed volume ``sum_z (a_z - o) . ((b_z - a_z) x (c_z - a_z)) / 6``
    is negative is wound inside out; its normals are flipped. The origin ``o``
    is the mean corner of the faces: on a closed mesh any origin gives the
    volume, on an open one (a raw scan or CAD export) this one keeps the test
    from depending on where the file puts its vertices.

    Returns
    -------
    normals : (k, 3) float64, areas : (k,) float64
    """
    normals, areas, _ = face_elements(as_mesh(mesh))
    return normals, areas


def face_elements(mesh: Mesh,
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`mesh_elements`, and the area of every face (zero for degenerate ones).

    Returns
    -------
    normals : (k, 3) float64, areas : (k,) float64, face_areas : (n_faces,) float64
        ``face_areas`` weighs :func:`vptoolkit.sphere.coarse_directions`, the
        sphere the estimate of a mesh is evaluated on.
    """
    cross = face_cross_products(mesh)
    double_areas = np.sqrt(np.einsum("ij,ij->i", cross, cross))
    keep = double_areas > 0
    if not keep.any():
        raise InputError(f"{mesh.name}: the mesh has zero surface area")
    incidence = np.bincount(mesh.faces[keep].ravel(), minlength=len(mesh.vertices))
    origin = incidence @ mesh.vertices / incidence.sum()  # the mean corner of the faces
    first = mesh.vertices[mesh.faces[:, 0]] - origin
    outward = 1.0 if float(np.einsum("ij,ij->", first, cross)) >= 0.0 else -1.0
    normals = cross[keep] * (outward / double_areas[keep, None])
    return normals, 0.5 * double_areas[keep], 0.5 * double_areas


def cloud_elements(cloud: PointCloud) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit normals and areas of the points of a cloud with normals, as surface elements.

    Each point stands for the area of surface around it
    (:func:`vptoolkit.point_areas.point_areas`), as the splats weigh it; its
    normal is taken as it is stored, so it must point outwards.

    Returns
    -------
    normals : (n_points, 3) float64, areas : (n_points,) float64

    Raises
    ------
    InputError
        The cloud has no normals (one line naming it).
    """
    if cloud.normals is None:
        raise InputError(f"{cloud.name}: a point cloud without normals; the occlusion-free "
                         "estimate reads the surface's normals (give points with normals: "
                         "an (N, 6) array x y z nx ny nz, or a PLY with nx ny nz)")
    return np.array(cloud.normals), point_areas(cloud.points)


def _pool(normals: NDArray[np.float64], areas: NDArray[np.float64], cells: int,
          ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Elements summed per cell of a ``cells x cells`` octahedral grid of their normals.

    Returns the cells' area-weighted mean unit normals, ``W = sum A_z`` and
    ``sum A_z log2 A_z``, for the cells of positive area.
    """
    folded = normals / np.abs(normals).sum(axis=1, keepdims=True)
    u, w, lower = folded[:, 0], folded[:, 1], folded[:, 2] < 0
    u, w = (np.where(lower, (1.0 - np.abs(w)) * np.where(u >= 0, 1.0, -1.0), u),
            np.where(lower, (1.0 - np.abs(u)) * np.where(w >= 0, 1.0, -1.0), w))
    column = np.clip(((u + 1.0) * (cells / 2.0)).astype(np.intp), 0, cells - 1)
    row = np.clip(((w + 1.0) * (cells / 2.0)).astype(np.intp), 0, cells - 1)
    cell = row * cells + column
    weights = np.bincount(cell, weights=areas, minlength=cells * cells)
    summed = np.stack([np.bincount(cell, weights=areas * normals[:, axis],
                                   minlength=cells * cells) for axis in range(3)], axis=1)
    a_log_a = np.bincount(cell, weights=_x_log2_x(areas), minlength=cells * cells)
    lengths = np.linalg.norm(summed, axis=1)
    used = (weights > 0) & (lengths > 0)
    return summed[used] / lengths[used, None], weights[used], a_log_a[used]


def unit_normals(normals: NDArray[np.float64], label: str) -> NDArray[np.float64]:
    """``normals`` made unit length, each finite and of positive length.

    Each row is divided by its largest absolute component before its length
    is taken, so a normal of any finite length (1e-300 or 1e300) comes out
    right, with no overflow or underflow.

    Parameters
    ----------
    normals : (k, 3) float64
    label : str
        Starts the message: the argument, or the file and model.

    Raises
    ------
    InputError
        ``<label>: a normal is NaN or infinite`` or ``<label>: 3 of 500
        normals have zero length``.
    """
    if not np.isfinite(normals).all():
        raise InputError(f"{label}: a normal is NaN or infinite")
    largest = np.abs(normals).max(axis=1, keepdims=True, initial=0.0)
    n_zero = int(np.count_nonzero(largest == 0.0))
    if n_zero:
        raise InputError(f"{label}: {n_zero} of {len(normals)} normals have zero length")
    scaled = normals / largest
    return np.asarray(scaled / np.linalg.norm(scaled, axis=1, keepdims=True))


def _x_log2_x(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """``x log2 x`` elementwise, 0 at 0."""
    return np.asarray(values * np.log2(np.maximum(values, _TINY)))


def unoccluded_quality(normals: ArrayLike, areas: ArrayLike, directions: ArrayLike, *,
                       cells: int | None = NORMAL_CELLS) -> NDArray[np.float64]:
    """Raw VE, VR, VKL and VMI with occlusion ignored (module docstring).

    Parameters
    ----------
    normals : (k, 3) array_like
        Outward normals of the surface elements (made unit length here).
    areas : (k,) array_like
        Their areas (any common unit; equal for a uniform point sample).
    directions : (n, 3) array_like
        Unit view directions.
    cells : int or None
        Pool the elements on a ``cells x cells`` octahedral grid of normals
        (default: 32); None keeps every element (exact, and slower on big meshes).

    Returns
    -------
    raw : (n, 4) float64
        In :data:`UNOCCLUDED_MEASURES` order; NaN where no element faces the direction.
    """
    vectors = np.asarray(normals, dtype=np.float64)
    element_areas = np.asarray(areas, dtype=np.float64)
    views = as_directions(directions)
    if vectors.ndim != 2 or vectors.shape[1] != 3 or element_areas.shape != vectors.shape[:1]:
        raise InputError(f"normals, areas: expected shapes (k, 3) and (k,), "
                         f"got {vectors.shape} and {element_areas.shape}")
    if not np.isfinite(element_areas).all() or (element_areas < 0).any():
        raise InputError("areas: expected finite values >= 0")
    unit = unit_normals(vectors, "normals")
    total = float(element_areas.sum())
    if not total > 0.0:
        raise InputError("areas: the surface has zero area")
    if cells is not None:
        if isinstance(cells, bool) or not isinstance(cells, (int, np.integer)) or cells < 1:
            raise InputError(f"cells: expected a positive integer or None, got {cells!r}")
        unit, weights, a_log_a = _pool(unit, element_areas, int(cells))
    else:
        weights, a_log_a = element_areas, _x_log2_x(element_areas)
    raw = np.full((len(views), len(UNOCCLUDED_MEASURES)), np.nan)
    step = max(1, _CHUNK_ENTRIES // len(weights))
    for start in range(0, len(views), step):
        facing = np.maximum(unit @ views[start:start + step].T, 0.0)  # c_z(d)
        a_t = weights @ facing
        seen = a_t > 0
        a_t = np.where(seen, a_t, 1.0)
        spread = weights @ _x_log2_x(facing)  # sum_z W_z c_z log2 c_z
        ve = np.log2(a_t) - (a_log_a @ facing + spread) / a_t
        kl = spread / a_t - np.log2(a_t) + math.log2(total)
        rows = np.stack([ve, a_t / total, kl, kl], axis=1)
        raw[start:start + step] = np.where(seen[:, None], rows, np.nan)
    return raw


def unoccluded_best_views(normals: ArrayLike, areas: ArrayLike | None = None, *,
                          directions: ArrayLike | int = UNOCCLUDED_DIRECTIONS,
                          measures: str | Iterable[str] | None = None,
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
    measures : str, iterable of str or None
        The measures to answer, any of :data:`UNOCCLUDED_MEASURES` in any
        order (:func:`unoccluded_measures`; default: the paper's four).

    Returns
    -------
    directions : (M, 3) float64
        Best unit direction per measure, in the order of ``measures`` (VMI's
        equals VKL's).

    Raises
    ------
    InputError
        For a measure without a closed form (:func:`unoccluded_measures`),
        or bad normals, areas or directions.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box(extents=(1, 2, 4))
    >>> normals, areas = mesh_elements(Mesh(box.vertices, box.faces))
    >>> unoccluded_best_views(normals, areas).shape
    (4, 3)
    """
    names = unoccluded_measures(measures)
    normals = np.asarray(normals, dtype=np.float64)
    if isinstance(directions, (int, np.integer)) and not isinstance(directions, bool):
        candidates = fibonacci_sphere(int(directions))
    else:
        candidates = as_directions(directions)
    weights = np.ones(len(normals)) if areas is None else areas
    raw = unoccluded_quality(normals, weights, candidates)
    return np.stack([candidates[ranked_views(raw, UNOCCLUDED_MEASURES.index(name))[0]]
                     for name in names])
