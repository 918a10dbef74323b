"""Candidate view directions on the unit sphere.

A view direction ``v`` is a unit vector pointing from the model's centre
towards the camera (see :mod:`vptoolkit.camera`). :func:`coarse_directions`
lays the Fibonacci sphere out in a mesh's principal frame, so the pattern
turns with the model (the best-view search's coarse sphere).
:func:`band_directions` lays one out over a band of elevations about an up
axis, and :func:`into_band` moves directions into such a band (the search's
``SearchSettings.elevation``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.conventions import N_VIEWS
from vptoolkit.errors import InputError
from vptoolkit.geometry import principal_frame
from vptoolkit.mesh import Mesh
from vptoolkit.point_cloud import PointCloud

__all__ = ["fibonacci_sphere", "coarse_directions", "nearest_view", "as_directions",
           "angle_between_deg", "is_zero_length", "distinct_directions", "elevation_deg",
           "band_directions", "into_band"]


def fibonacci_sphere(n: int = N_VIEWS) -> NDArray[np.float64]:
    """Return ``n`` almost evenly spread unit directions, in the authors' order.

    For ``i = 0 .. n-1``, with ``offset = 2 / n`` and the golden angle
    ``inc = pi (3 - sqrt 5)``::

        y   = i * offset - 1 + offset / 2
        r   = sqrt(1 - y^2)
        phi = ((i + 1) mod n) * inc
        v_i = (cos(phi) r, y, sin(phi) r)

    This matches the view order of the paper's released data, so indices into
    the returned array are interchangeable with theirs.

    Parameters
    ----------
    n : int
        Number of directions, at least 1 (default: 1000).

    Returns
    -------
    directions : (n, 3) float64
        Unit vectors, ``y`` increasing with the index from about -1 to 1.

    Examples
    --------
    >>> fibonacci_sphere(4).round(3)[0]
    array([-0.488, -0.75 ,  0.447])
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f"n: number of views must be a positive integer, got {n!r}")
    index = np.arange(n, dtype=np.float64)
    offset = 2.0 / n
    increment = math.pi * (3.0 - math.sqrt(5.0))
    y = index * offset - 1.0 + offset / 2.0
    radius = np.sqrt(np.maximum(0.0, 1.0 - y * y))
    phi = ((np.arange(n) + 1) % n) * increment
    return np.stack([np.cos(phi) * radius, y, np.sin(phi) * radius], axis=1)


def as_directions(directions: ArrayLike, *, name: str = "directions") -> NDArray[np.float64]:
    """Check and normalise an array of directions to unit length.

    Parameters
    ----------
    directions : (n, 3) or (3,) array_like
        Non-zero, finite vectors.
    name : str
        Argument name used in error messages (default: "directions").

    Returns
    -------
    unit : (n, 3) float64
        The directions scaled to unit length (a single vector becomes ``(1, 3)``).

    Raises
    ------
    InputError
        On a wrong shape, NaN or infinite entries, or a zero vector.
    """
    try:
        array = np.array(directions, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f"{name}: not a numeric array ({err})") from err
    if array.ndim == 1:
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] != 3:
        raise InputError(f"{name}: expected shape (n, 3), got {np.shape(directions)}")
    if not np.isfinite(array).all():
        raise InputError(f"{name}: contains NaN or infinite values")
    is_zero = is_zero_length(array)
    if is_zero.any():
        raise InputError(f"{name}: contains {int(is_zero.sum())} zero-length vectors")
    scaled = _largest_component_one(array)
    return scaled / np.linalg.norm(scaled, axis=1)[:, None]


def _largest_component_one(vectors: NDArray[np.float64]) -> NDArray[np.float64]:
    """Each finite vector divided by its largest absolute component (zero vectors kept).

    Its length is then 1 to sqrt(3), so no square overflows near the largest
    float (1.7e308) or underflows near the smallest.
    """
    scale = np.abs(vectors).max(axis=-1, keepdims=True)
    return vectors / np.where(scale > 0, scale, 1.0)


def is_zero_length(vectors: ArrayLike) -> NDArray[np.bool_]:
    """Whether each finite vector (along the last axis) is shorter than 1e-12.

    Computed without squaring the components as they are, so vectors near
    the largest float give no overflow warning and count as long.
    """
    values = np.asarray(vectors, dtype=np.float64)
    scale = np.abs(values).max(axis=-1)
    tiny = scale < 1e-12  # longer vectors are never shorter than their largest component
    lengths = np.where(tiny, scale, 0.0) * np.linalg.norm(_largest_component_one(values), axis=-1)
    return tiny & (lengths < 1e-12)


def coarse_directions(mesh: Mesh | PointCloud, n: int, areas: NDArray[np.float64] | None = None,
                      ) -> NDArray[np.float64]:
    """``n`` Fibonacci directions in the mesh's principal frame, the poles on its least-spread axis.

    The frame is :func:`vptoolkit.geometry.principal_frame` (``areas``: the
    face areas, computed when not given; a point cloud's point areas), so
    the pattern turns with the model
    and any input orientation is covered alike.

    Returns
    -------
    directions : (n, 3) float64
        Unit vectors in the mesh's coordinates.
    """
    largest, middle, smallest = principal_frame(mesh, areas)
    sphere = fibonacci_sphere(n)  # poles along y
    return sphere[:, :1] * largest + sphere[:, 1:2] * smallest + sphere[:, 2:] * middle


def nearest_view(
    directions: ArrayLike, view_directions: ArrayLike
) -> NDArray[np.int64]:
    """Index of the closest candidate view for each direction.

    Closeness is the angle between unit vectors, i.e. the largest dot product.

    Parameters
    ----------
    directions : (n, 3) or (3,) array_like
        Query directions (any non-zero length; they are normalised).
    view_directions : (m, 3) array_like
        Candidate view directions, e.g. :func:`fibonacci_sphere`.

    Returns
    -------
    index : (n,) int64
        Row of ``view_directions`` nearest to each query.

    Examples
    --------
    >>> views = fibonacci_sphere(1000)
    >>> int(nearest_view(views[17] * 3.0, views)[0])
    17
    """
    queries = as_directions(directions)
    candidates = as_directions(view_directions, name="view_directions")
    return np.argmax(queries @ candidates.T, axis=1).astype(np.int64)


def angle_between_deg(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Angle in degrees between matching rows of two direction arrays.

    Parameters
    ----------
    a, b : (n, 3) or (3,) array_like
        Non-zero directions; broadcast against each other row by row.

    Returns
    -------
    angle : (n,) float64
        In degrees, in [0, 180].
    """
    unit_a = as_directions(a, name="a")
    unit_b = as_directions(b, name="b")
    cosine = np.clip(np.sum(unit_a * unit_b, axis=1), -1.0, 1.0)
    return np.degrees(np.arccos(cosine))


def distinct_directions(directions: NDArray[np.float64],
                        min_angle_deg: float) -> NDArray[np.float64]:
    """The directions in order, without any closer than ``min_angle_deg`` to an earlier one.

    Parameters
    ----------
    directions : (n, 3) float64
        Unit vectors.
    min_angle_deg : float
        Smallest angle between two kept directions, in degrees.

    Returns
    -------
    kept : (k, 3) float64
    """
    limit = math.cos(math.radians(min_angle_deg))
    kept: list[NDArray[np.float64]] = []
    for direction in directions:
        if all(float(direction @ other) < limit for other in kept):
            kept.append(direction)
    return np.array(kept).reshape(-1, 3)


def elevation_deg(directions: ArrayLike, up: ArrayLike) -> NDArray[np.float64]:
    """Elevation ``asin(v . u)`` in degrees of unit directions ``(n, 3)`` above the horizon of
    the unit axis ``u``: ``(n,)`` float64 in [-90, 90]."""
    sine = np.asarray(directions, dtype=np.float64) @ np.asarray(up, dtype=np.float64)
    return np.degrees(np.arcsin(np.clip(sine, -1.0, 1.0)))


def _horizon_frame(up: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two unit vectors that span the horizon of the unit axis ``up``, right-handed with it."""
    first = np.cross(up, np.eye(3)[int(np.argmin(np.abs(up)))])
    first /= np.linalg.norm(first)
    return first, np.cross(up, first)


def band_directions(n: int, up: ArrayLike, elevation: tuple[float, float]
                    ) -> NDArray[np.float64]:
    """``n`` Fibonacci directions evenly spread over a band of elevations around ``up``.

    Direction ``i`` has ``sin(elevation_i) = s_low + (s_high - s_low) (i + 1/2) / n``
    (equal areas, since a band's area grows linearly with the sine) and azimuth
    ``i`` times the golden angle ``pi (3 - sqrt 5)``, both about the unit axis
    ``up``; ``elevation = (low, high)`` in degrees.

    Returns
    -------
    directions : (n, 3) float64
        Unit vectors, every one with elevation in ``[low, high]``.
    """
    axis = np.asarray(up, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    first, second = _horizon_frame(axis)
    low, high = (math.sin(math.radians(angle)) for angle in elevation)
    sine = low + (high - low) * (np.arange(n) + 0.5) / n
    cosine = np.sqrt(np.clip(1.0 - sine * sine, 0.0, 1.0))
    azimuth = np.arange(n) * math.pi * (3.0 - math.sqrt(5.0))
    return np.asarray(sine[:, None] * axis + cosine[:, None] * (
        np.cos(azimuth)[:, None] * first + np.sin(azimuth)[:, None] * second))


def into_band(directions: ArrayLike, up: ArrayLike, elevation: tuple[float, float]
              ) -> NDArray[np.float64]:
    """Unit directions ``(n, 3)`` moved along their meridian into the band ``elevation``.

    The elevation about the unit axis ``up`` is clamped to ``[low, high]``
    degrees and the azimuth kept; a direction along ``up`` or ``-up`` (no
    azimuth) takes that of the horizon frame's first axis.

    Returns
    -------
    directions : (n, 3) float64
        Unit vectors; those already in the band are returned unchanged.
    """
    points = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    axis = np.asarray(up, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    angles = elevation_deg(points, axis)
    clamped = np.clip(angles, *elevation)
    horizontal = points - (points @ axis)[:, None] * axis
    lengths = np.linalg.norm(horizontal, axis=1, keepdims=True)
    first, _ = _horizon_frame(axis)
    horizontal = np.where(lengths > 1e-12, horizontal / np.where(lengths > 1e-12, lengths, 1.0),
                          first)
    moved = (np.sin(np.radians(clamped))[:, None] * axis
             + np.cos(np.radians(clamped))[:, None] * horizontal)
    return np.where((angles == clamped)[:, None], points, moved)
