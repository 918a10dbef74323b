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
mesh has one) and the candidate proposer of :class:`UnoccludedPrior` for
:func:`vptoolkit.best_view.search.search_best_views`. It is exact for a convex surface
seen from afar (orthographically) and misleads where parts hide each other.

Directions are unit vectors from the model's centre towards the camera, in the
model's own coordinates. Numpy only.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.errors import InputError
from vptoolkit.geometry import face_cross_products
from vptoolkit.measures.quality import ranked_views
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.mesh import Mesh, MeshLike, as_mesh
from vptoolkit.predictions import Predictions
from vptoolkit.sphere import (
    as_directions,
    coarse_directions,
    distinct_directions,
    fibonacci_sphere,
)

if TYPE_CHECKING:
    from vptoolkit.data import ViewpointDataset

__all__ = [
    "NORMAL_CELLS",
    "UNOCCLUDED_DIRECTIONS",
    "UnoccludedPrior",
    "mesh_elements",
    "predict_unoccluded",
    "unoccluded_best_views",
    "unoccluded_quality",
]

UNOCCLUDED_DIRECTIONS: Final = 128
"""Default number of directions the estimate is evaluated at (about 18 degrees apart)."""

NORMAL_CELLS: Final = 32
"""Side of the octahedral grid the elements' normals are pooled on (1024 cells)."""

_CHUNK_ENTRIES = 1 << 21  # elements x directions per block of the product (16 MiB of float64)
_TINY = np.finfo(np.float64).tiny
_RANKED = 32  # best directions per measure looked through for distinct candidates


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
    mesh = as_mesh(mesh)
    normals, areas, _ = _face_elements(mesh)
    return normals, areas


def _face_elements(mesh: Mesh,
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`mesh_elements`, and the area of every face (zero for degenerate ones)."""
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


def _unit_normals(normals: NDArray[np.float64], label: str) -> NDArray[np.float64]:
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
        In ``PAPER_MEASURES`` order; NaN where no element faces the direction.
    """
    vectors = np.asarray(normals, dtype=np.float64)
    element_areas = np.asarray(areas, dtype=np.float64)
    views = as_directions(directions)
    if vectors.ndim != 2 or vectors.shape[1] != 3 or element_areas.shape != vectors.shape[:1]:
        raise InputError(f"normals, areas: expected shapes (k, 3) and (k,), "
                         f"got {vectors.shape} and {element_areas.shape}")
    if not np.isfinite(element_areas).all() or (element_areas < 0).any():
        raise InputError("areas: expected finite values >= 0")
    unit = _unit_normals(vectors, "normals")
    total = float(element_areas.sum())
    if not total > 0.0:
        raise InputError("areas: the surface has zero area")
    if cells is not None:
        if isinstance(cells, bool) or not isinstance(cells, (int, np.integer)) or cells < 1:
            raise InputError(f"cells: expected a positive integer or None, got {cells!r}")
        unit, weights, a_log_a = _pool(unit, element_areas, int(cells))
    else:
        weights, a_log_a = element_areas, _x_log2_x(element_areas)
    raw = np.full((len(views), len(PAPER_MEASURES)), np.nan)
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
        Best unit direction per measure in ``PAPER_MEASURES`` order (VMI's equals VKL's).

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box(extents=(1, 2, 4))
    >>> normals, areas = mesh_elements(Mesh(box.vertices, box.faces))
    >>> unoccluded_best_views(normals, areas).shape
    (4, 3)
    """
    normals = np.asarray(normals, dtype=np.float64)
    if isinstance(directions, (int, np.integer)) and not isinstance(directions, bool):
        candidates = fibonacci_sphere(int(directions))
    else:
        candidates = as_directions(directions)
    weights = np.ones(len(normals)) if areas is None else areas
    raw = unoccluded_quality(normals, weights, candidates)
    return np.stack([candidates[ranked_views(raw, column)[0]]
                     for column in range(len(PAPER_MEASURES))])


class UnoccludedPrior:
    """Candidate directions of a mesh from the occlusion-free estimate, for the search.

    The estimate is evaluated on ``n_directions`` directions of the mesh's
    principal-frame Fibonacci sphere (:func:`vptoolkit.sphere.coarse_directions`,
    so it turns with the mesh); the candidates are each of VE, VR and VKL's
    best ``per_measure`` directions at least ``min_angle_deg`` apart, rank by
    rank in ``PAPER_MEASURES`` order (VMI's estimate is VKL's), duplicates dropped.
    No image is drawn; the cost is a pass over the faces and one product of at
    most 1024 pooled normals with ``n_directions`` directions.

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
    >>> found = search_best_views(mesh, SearchSettings(budget=16),  # doctest: +SKIP
    ...                           prior=UnoccludedPrior()(mesh))
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

    def __call__(self, mesh: MeshLike) -> NDArray[np.float64]:
        """Candidate unit directions ``(k, 3)``, most promising first."""
        mesh = as_mesh(mesh)
        normals, areas, face_areas = _face_elements(mesh)
        directions = coarse_directions(mesh, self.n_directions, face_areas)
        raw = unoccluded_quality(normals, areas, directions)
        measures = [PAPER_MEASURES.index(name) for name in ("VE", "VR", "VKL")]
        per_measure = [distinct_directions(directions[ranked_views(raw, column)[:_RANKED]],
                                           self.min_angle_deg)[:self.per_measure]
                       for column in measures]
        ranked = [found[rank] for rank in range(self.per_measure)
                  for found in per_measure if rank < len(found)]
        return distinct_directions(np.array(ranked).reshape(-1, 3), 1.0)


def predict_unoccluded(
    inputs: (str | os.PathLike[str] | ViewpointDataset
             | Sequence[str | os.PathLike[str] | ViewpointDataset]),
    *,
    split: str | None = "test",
    n_directions: int = UNOCCLUDED_DIRECTIONS,
) -> Predictions:
    """:func:`unoccluded_best_views` of mesh files, point files with normals and dataset splits.

    Parameters
    ----------
    inputs : path-like, ViewpointDataset or a sequence of them
        Mesh files (their faces, on the mesh's principal-frame sphere of
        ``n_directions``, :func:`vptoolkit.sphere.coarse_directions`),
        ``(N, 6)`` ``.npy`` point files (``x y z nx ny nz``; on the Fibonacci
        sphere of ``n_directions``) and datasets (their stored points' normals,
        likewise), in any mix, told apart by :func:`vptoolkit.inputs.open_inputs`.
        Names: file stems, or the dataset's.
    split : str, optional
        Split of dataset inputs, or None for every model (default: "test").
    n_directions : int
        Directions the estimate is evaluated at (default: 128).

    Returns
    -------
    Predictions
        ``names`` and ``directions (n_models, 4, 3) float64``: unit directions
        in ``PAPER_MEASURES`` order, each in its input's own frame.

    Raises
    ------
    InputError
        Naming the input, on an unreadable file, a point file without normals,
        an unknown file type or split, two models of one name, or a normal
        that is NaN, infinite or of zero length (naming the dataset and model
        for a stored one).
    """
    from vptoolkit.inputs import claim_name, open_inputs

    names: set[str] = set()
    answers: list[NDArray[np.float64]] = []
    with open_inputs(inputs, split=split) as sources:
        for source in sources:
            claim_name(names, source.name)
            if source.kind == "mesh":
                mesh = source.mesh()
                normals, areas, face_areas = _face_elements(mesh)
                answers.append(unoccluded_best_views(
                    normals, areas, directions=coarse_directions(mesh, n_directions, face_areas)))
            elif source.kind == "points":
                answers.append(unoccluded_best_views(source.normals(), directions=n_directions))
            else:
                answers.append(unoccluded_best_views(
                    _unit_normals(source.normals(), f"{source.origin}: model {source.name!r}"),
                    directions=n_directions))
        ordered = tuple(source.name for source in sources)
    return Predictions(ordered, np.array(answers).reshape(-1, len(PAPER_MEASURES), 3))
