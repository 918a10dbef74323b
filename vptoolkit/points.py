"""Point clouds from meshes: uniform surface sampling and the network input.

The paper feeds its network point clouds only (Schelling et al. 2021, section
"Data"): every cleaned mesh is turned into 20k points sampled uniformly on its
faces (:func:`sample_surface`), and each training input takes 4096 of them,
1024 by farthest point sampling plus 3072 others at random
(:func:`network_input`, :func:`network_input_indices`,
:func:`farthest_point_sampling`).

Blue-noise points (:func:`poisson_disk_points`, figure-5-style robustness
tests with an other sampling than the training's) use Open3D's sample
elimination, imported when called; everything else is numpy only. All of it
is deterministic for a given seed or generator; no function touches the
global random state.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import check_int
from vptoolkit.errors import InputError
from vptoolkit.mesh import MeshLike, as_mesh

__all__ = [
    "MAX_SURFACE_POINTS",
    "N_SURFACE_POINTS",
    "N_NETWORK_POINTS",
    "N_FPS_POINTS",
    "SurfaceSample",
    "sample_surface",
    "farthest_point_sampling",
    "network_input_indices",
    "network_input",
    "poisson_disk_points",
]

N_SURFACE_POINTS = 20_000
"""Points sampled on each mesh surface (the paper's 20k)."""

MAX_SURFACE_POINTS = 100_000_000
"""Most points :func:`sample_surface` draws: about 10 GB of work arrays at float64."""

N_NETWORK_POINTS = 4096
"""Points in one network input (the paper's 4096)."""

N_FPS_POINTS = 1024
"""Points of the network input chosen by farthest point sampling (the paper's 1024)."""


class SurfaceSample(NamedTuple):
    """Points sampled on a mesh surface, with the normal and face of each.

    A named tuple, so ``points, normals, face_index = sample_surface(mesh)``
    works as well as ``sample.points``.

    Attributes
    ----------
    points : (n_points, 3) float64
        Positions on the surface, in model units.
    normals : (n_points, 3) float64
        Unit normal of the face each point lies on (right-hand rule over the
        face's vertex order).
    face_index : (n_points,) int64
        Index into ``mesh.faces`` of the face each point lies on.
    """

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    face_index: NDArray[np.int64]


def sample_surface(mesh: MeshLike, n: int = N_SURFACE_POINTS, *, seed: int = 0) -> SurfaceSample:
    """Sample points uniformly by area on the faces of a mesh.

    Each point picks a face with probability proportional to its area, then a
    uniform position inside it: with ``u, v ~ U[0, 1)`` reflected to
    ``u + v <= 1`` when their sum exceeds 1, the point is
    ``a + u (b - a) + v (c - a)`` for the face corners ``a, b, c``. Faces of
    zero area are never picked.

    Parameters
    ----------
    mesh : MeshLike
        The surface to sample; its total area must be positive.
    n : int
        Number of points, 1 to :data:`MAX_SURFACE_POINTS` (default: 20000, the paper's choice).
    seed : int
        Seed (>= 0) of the ``numpy.random.Generator`` used; the same mesh, ``n`` and
        seed always give the same sample (default: 0).

    Returns
    -------
    SurfaceSample
        ``points (n, 3) float64``, ``normals (n, 3) float64`` (unit face
        normals) and ``face_index (n,) int64``.

    Raises
    ------
    InputError
        If ``mesh`` is not a :class:`~vptoolkit.mesh.Mesh`, ``n`` is not a
        positive integer, ``seed`` is not an integer, or the mesh has zero area.

    Examples
    --------
    >>> import numpy as np
    >>> square = (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float),
    ...           np.array([[0, 1, 2], [0, 2, 3]]))
    >>> sample = sample_surface(square, 1000, seed=1)
    >>> sample.points.shape, sample.normals[0].tolist()
    ((1000, 3), [0.0, 0.0, 1.0])
    """
    mesh = as_mesh(mesh)
    n = check_int(n, "n", minimum=1, maximum=MAX_SURFACE_POINTS)
    seed = check_int(seed, "seed", minimum=0)  # numpy refuses negative seeds

    corners = mesh.vertices[mesh.faces]  # (n_faces, 3 corners, 3)
    edge_b = corners[:, 1] - corners[:, 0]
    edge_c = corners[:, 2] - corners[:, 0]
    cross = np.cross(edge_b, edge_c)
    double_areas = np.linalg.norm(cross, axis=1)
    cumulative = np.cumsum(double_areas)
    total = float(cumulative[-1])
    if not total > 0.0:
        raise InputError(f"{mesh.name}: mesh has zero surface area, nothing to sample")

    rng = np.random.default_rng(int(seed))
    # side="right" maps a draw equal to a boundary to the next face of
    # positive area, so zero-area faces (empty intervals) are never chosen.
    face_index = np.searchsorted(cumulative, rng.random(n) * total, side="right")
    face_index = np.minimum(face_index, len(cumulative) - 1).astype(np.int64)
    u, v = rng.random((2, n))
    outside = u + v > 1.0
    u[outside] = 1.0 - u[outside]
    v[outside] = 1.0 - v[outside]
    points = (
        corners[face_index, 0]
        + u[:, None] * edge_b[face_index]
        + v[:, None] * edge_c[face_index]
    )
    normals = cross[face_index] / double_areas[face_index, None]
    return SurfaceSample(points=points, normals=normals, face_index=face_index)


def farthest_point_sampling(
    points: ArrayLike,
    n_samples: int,
    *,
    rng: np.random.Generator | None = None,
    start_index: int | None = None,
) -> NDArray[np.int64]:
    """Pick points that are greedily as far as possible from those already picked.

    Farthest point sampling (Eldar et al. 1997): start from one point, then
    repeatedly add the point whose distance to the nearest picked point is
    largest. Each of the ``n_samples - 1`` steps updates the nearest-pick
    distance of all points in one vectorised pass, so the cost is
    ``O(n_points * n_samples)`` with a small constant (20k -> 1024 takes a few
    tens of milliseconds).

    Parameters
    ----------
    points : (n_points, 3) array_like
        Finite coordinates.
    n_samples : int
        Number of points to pick, ``1 <= n_samples <= n_points``.
    rng : numpy.random.Generator, optional
        Draws the starting point when ``start_index`` is not given.
    start_index : int, optional
        Index of the first pick. When neither ``start_index`` nor ``rng`` is
        given, the first pick is point 0.

    Returns
    -------
    indices : (n_samples,) int64
        Distinct indices into ``points``, in the order picked.

    Raises
    ------
    InputError
        On a wrong shape or non-finite coordinates, an ``n_samples`` outside
        ``1 .. n_points``, a ``start_index`` out of range or an ``rng`` that is
        not a ``numpy.random.Generator``.

    Notes
    -----
    Distances are computed on centred coordinates in float32 as
    ``|p|^2 - 2 p.q + |q|^2``; rounding can only swap picks between points
    whose distances agree to about seven significant digits.
    """
    cloud = _as_points(points, "points")
    n_points = len(cloud)
    n_samples = check_int(n_samples, "n_samples", minimum=1)
    if n_samples > n_points:
        raise InputError(
            f"n_samples: cannot pick {n_samples} distinct points from {n_points} points"
        )
    if start_index is None:
        start_index = 0 if rng is None else int(_generator(rng).integers(n_points))
    elif (
        isinstance(start_index, bool)
        or not isinstance(start_index, (int, np.integer))
        or not 0 <= start_index < n_points
    ):
        raise InputError(
            f"start_index: expected an integer in [0, {n_points}), got {start_index!r}"
        )

    centred = cloud - cloud.mean(axis=0)
    scale = float(np.abs(centred).max())
    if scale > 0.0:
        centred /= scale
    coords = centred.astype(np.float32)
    squared_norms = np.einsum("ij,ij->i", coords, coords)
    nearest = np.full(n_points, np.inf, dtype=np.float32)
    distance = np.zeros(n_points, dtype=np.float32)
    indices = np.zeros(n_samples, dtype=np.int64)
    current = int(start_index)
    indices[0] = current
    nearest[current] = -np.inf
    for step in range(1, n_samples):
        pick = coords[current]
        np.dot(coords, pick, out=distance)
        distance *= -2.0
        distance += squared_norms
        distance += squared_norms[current]
        np.minimum(nearest, distance, out=nearest)
        current = int(nearest.argmax())
        indices[step] = current
        nearest[current] = -np.inf  # never pick a point twice, even among duplicates
    return indices


def network_input_indices(
    points: ArrayLike,
    n: int = N_NETWORK_POINTS,
    n_fps: int = N_FPS_POINTS,
    *,
    rng: np.random.Generator,
    fps_indices: ArrayLike | None = None,
) -> NDArray[np.int64]:
    """Choose the points of one network input, as indices into ``points``.

    The paper's input (section "Data", augmentation 1): ``n_fps`` points by
    farthest point sampling from a random start, plus ``n - n_fps`` random
    other points. The random part is drawn without replacement from the
    points that farthest point sampling did not pick. When fewer remain than
    needed, it holds every remaining point once plus draws with replacement
    from them (from all points when farthest point sampling took every one),
    in random order.

    Use the indices to gather matching normals or face indices of a
    :class:`SurfaceSample`.

    Parameters
    ----------
    points : (n_points, 3) array_like
        The sampled surface, usually ``sample_surface(mesh).points``.
    n : int
        Size of the input, at least 1 (default: 4096).
    n_fps : int
        How many of them farthest point sampling picks,
        ``0 <= n_fps <= min(n, n_points)`` (default: 1024).
    rng : numpy.random.Generator
        Source of the start point and the random part.
    fps_indices : (n_fps,) array_like of int, optional
        Farthest-point picks made earlier (e.g. a training cache); when given
        they are used as they are and only the random part is drawn.

    Returns
    -------
    indices : (n,) int64
        First the ``n_fps`` farthest-point picks in picking order, then the
        random ones.

    Raises
    ------
    InputError
        If ``points`` has a wrong shape or non-finite values, there are fewer
        points than ``n_fps``, ``n_fps`` exceeds ``n``, or ``rng`` is not a
        ``numpy.random.Generator``.
    """
    cloud = _as_points(points, "points")
    n = check_int(n, "n", minimum=1)
    if isinstance(n_fps, bool) or not isinstance(n_fps, (int, np.integer)) or n_fps < 0:
        raise InputError(f"n_fps: expected a non-negative integer, got {n_fps!r}")
    if n_fps > n:
        raise InputError(f"n_fps: {n_fps} farthest points exceed the input size n={n}")
    if len(cloud) < n_fps:
        raise InputError(
            f"points: {len(cloud)} points, fewer than the n_fps={n_fps} farthest points asked for"
        )
    rng = _generator(rng)
    if fps_indices is not None:
        fps = np.asarray(fps_indices, dtype=np.int64)
        if fps.shape != (n_fps,) or (n_fps and not (0 <= fps.min() and fps.max() < len(cloud))):
            raise InputError(f"fps_indices: expected {n_fps} indices into {len(cloud)} points, "
                             f"got shape {fps.shape}")
    elif n_fps > 0:
        fps = farthest_point_sampling(cloud, n_fps, rng=rng)
    else:
        fps = np.zeros(0, dtype=np.int64)
    n_random = n - n_fps
    is_free = np.ones(len(cloud), dtype=bool)
    is_free[fps] = False
    free = np.flatnonzero(is_free)
    if len(free) == 0:
        free = np.arange(len(cloud), dtype=np.int64)
    if n_random <= len(free):
        random_part = rng.choice(free, size=n_random, replace=False)
    else:
        # Every remaining point once, the rest drawn with replacement, shuffled.
        extra = rng.choice(free, size=n_random - len(free), replace=True)
        random_part = rng.permutation(np.concatenate([free, extra]))
    return np.concatenate([fps, random_part.astype(np.int64)])


def network_input(
    points: ArrayLike,
    n: int = N_NETWORK_POINTS,
    n_fps: int = N_FPS_POINTS,
    *,
    rng: np.random.Generator,
) -> NDArray[np.float64]:
    """Return the points of one network input (see :func:`network_input_indices`).

    Parameters
    ----------
    points : (n_points, 3) array_like
        The sampled surface, usually ``sample_surface(mesh).points``.
    n : int
        Size of the input (default: 4096).
    n_fps : int
        How many of them farthest point sampling picks (default: 1024).
    rng : numpy.random.Generator
        Source of the start point and the random part.

    Returns
    -------
    input_points : (n, 3) float64
        The ``n_fps`` farthest-point picks first, then the random ones.

    Raises
    ------
    InputError
        As :func:`network_input_indices`.

    Examples
    --------
    >>> import numpy as np
    >>> cloud = np.random.default_rng(0).normal(size=(20000, 3))
    >>> network_input(cloud, rng=np.random.default_rng(1)).shape
    (4096, 3)
    """
    cloud = _as_points(points, "points")
    return cloud[network_input_indices(cloud, n, n_fps, rng=rng)]


def poisson_disk_points(
    mesh: MeshLike, n: int, *, seed: int = 0, oversampling: int = 5
) -> NDArray[np.float64]:
    """``n`` blue-noise surface points by Yuksel's sample elimination (Open3D).

    Starts from ``oversampling * n`` area-uniform points
    (:func:`sample_surface` with ``seed``) and eliminates down to ``n``
    points of about equal spacing (Open3D's
    ``TriangleMesh.sample_points_poisson_disk`` given that point cloud), so
    the result is deterministic. Needs Open3D (``pip install vptoolkit[measures]``).

    Parameters
    ----------
    mesh : MeshLike
        The surface.
    n : int
        Points wanted (at least 1).
    seed : int
        Seed of the uniform candidates (default: 0).
    oversampling : int
        Candidates per wanted point (default: 5, Yuksel's suggestion).

    Returns
    -------
    points : (n, 3) float64

    Raises
    ------
    InputError
        On a bad argument or a mesh without area.
    MissingDependencyError
        Without Open3D.
    """
    mesh = as_mesh(mesh)
    from vptoolkit.optional import require

    n = check_int(n, "n", minimum=1)
    oversampling = check_int(oversampling, "oversampling", minimum=1)
    candidates = sample_surface(mesh, oversampling * n, seed=seed)
    o3d = require("open3d", extra="measures")
    triangles = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(np.array(mesh.vertices, dtype=np.float64)),
        o3d.utility.Vector3iVector(np.array(mesh.faces, dtype=np.int32)),
    )
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(candidates.points))
    cloud.normals = o3d.utility.Vector3dVector(candidates.normals)
    return np.asarray(triangles.sample_points_poisson_disk(n, pcl=cloud).points, dtype=np.float64)


def _as_points(points: ArrayLike, what: str) -> NDArray[np.float64]:
    try:
        cloud = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f"{what}: cannot be read as float64: {err}") from err
    if cloud.ndim != 2 or cloud.shape[1] != 3:
        raise InputError(f"{what}: expected shape (n, 3), got {cloud.shape}")
    if len(cloud) == 0:
        raise InputError(f"{what}: no points")
    if not np.isfinite(cloud).all():
        raise InputError(f"{what}: contains NaN or infinite coordinates")
    return cloud


def _generator(rng: np.random.Generator) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise InputError(
            f"rng: expected a numpy.random.Generator (np.random.default_rng(seed)), "
            f"got {type(rng).__name__}"
        )
    return rng
