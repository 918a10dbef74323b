"""Candidate view directions on the unit sphere.

A view direction ``v`` is a unit vector pointing from the model's centre
towards the camera (see :mod:`vptoolkit.camera`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.conventions import N_VIEWS
from vptoolkit.errors import InputError

__all__ = ["fibonacci_sphere", "nearest_view", "as_directions", "angle_between_deg"]


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
    norms = np.linalg.norm(array, axis=1)
    if (norms < 1e-12).any():
        raise InputError(f"{name}: contains {int((norms < 1e-12).sum())} zero-length vectors")
    return array / norms[:, None]


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
