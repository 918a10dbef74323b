"""Baseline viewpoint predictors to compare a network with.

:func:`random_directions` (uniform on the sphere), :func:`pca_directions`
(view along the smallest principal axis) and :func:`oracle_directions` (the
dataset's own best views, 100 % under
:func:`vptoolkit.evaluate.scores.score_directions` by construction). Each
returns ``(n_models, M, 3)`` float64 unit vectors, one per measure, the form
every scorer takes: ``M`` is given (``n_measures``, by default the paper's
four, ``len(PAPER_MEASURES)``; pass ``len(dataset.measures)`` for a dataset
recorded with other measures), and the oracle takes the dataset's own.
Numpy only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import check_int, one_line
from vptoolkit.data import ViewpointDataset
from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES

__all__ = ["random_directions", "pca_directions", "oracle_directions"]

_SYMMETRY_TOLERANCE = 1e-9  # |third moment| / std**3 below which a cloud counts as symmetric


def random_directions(n: int, *, seed: int,
                      n_measures: int = len(PAPER_MEASURES)) -> NDArray[np.float64]:
    """Directions drawn uniformly on the unit sphere, independently per measure.

    Normalised standard-normal vectors, from ``np.random.default_rng(seed)``,
    drawn model by model, measure by measure (so the paper's four draw what
    they always drew).

    Parameters
    ----------
    n : int
        Number of models, at least 0.
    seed : int
        Seed of the generator; the same seed gives the same array.
    n_measures : int
        Directions per model, at least 1 (default: 4, the paper's measures).

    Returns
    -------
    directions : (n, n_measures, 3) float64
        Unit vectors.

    Raises
    ------
    InputError
        If ``n`` is negative, ``n_measures`` below 1 or an argument is not an
        integer.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise InputError(f"n: expected a non-negative integer, got {n!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise InputError(f"seed: expected an integer, got {seed!r}")
    n_measures = check_int(n_measures, "n_measures", minimum=1)
    rng = np.random.default_rng(int(seed))
    directions = np.zeros((int(n), n_measures, 3))
    is_todo = np.ones(directions.shape[:2], dtype=bool)
    while is_todo.any():  # redraw the (practically impossible) near-zero draws
        directions[is_todo] = rng.standard_normal((int(is_todo.sum()), 3))
        is_todo = np.linalg.norm(directions, axis=2) < 1e-12
    return np.asarray(directions / np.linalg.norm(directions, axis=2, keepdims=True))


def _pca_direction(points: NDArray[np.float64], label: str) -> NDArray[np.float64]:
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"{label}: expected shape (n_points, 3), got {points.shape}")
    if points.shape[0] < 3:
        raise InputError(f"{label}: needs at least 3 points, got {points.shape[0]}")
    if not np.isfinite(points).all():
        raise InputError(f"{label}: contains NaN or infinite values")
    centred = points - points.mean(axis=0)
    eigenvalues, eigenvectors = np.linalg.eigh(centred.T @ centred / len(points))
    if eigenvalues[-1] <= 1e-24:
        raise InputError(f"{label}: all points coincide")
    axis = eigenvectors[:, 0]  # smallest principal axis (eigh sorts ascending)
    projection = centred @ axis
    spread = float(np.mean(projection**2))
    third_moment = float(np.mean(projection**3))
    if abs(third_moment) > _SYMMETRY_TOLERANCE * max(spread, 1e-300) ** 1.5:
        sign = -math.copysign(1.0, third_moment)
    else:
        sign = math.copysign(1.0, axis[int(np.argmax(np.abs(axis)))])
    unit = sign * axis
    return np.asarray(unit / np.linalg.norm(unit))


def pca_directions(points: ArrayLike | Sequence[ArrayLike], *,
                   n_measures: int = len(PAPER_MEASURES)) -> NDArray[np.float64]:
    """A PCA heuristic: look along each model's smallest principal axis.

    Viewing along the eigenvector of the smallest eigenvalue of the point
    covariance puts the two largest principal axes in the image plane, so the
    model shows its largest extent. The sign is chosen by the third central
    moment of the points projected onto that axis: the camera goes on the
    side of the bulk of the points, away from the long tail (a table seen
    along its height is viewed from the top, not from the end of its legs).
    If the projection is symmetric (``|third moment| <= 1e-9 std**3``), the
    component of largest magnitude is made positive. The rule only uses the
    points, so rotating a model rotates its direction with it (except in the
    symmetric fallback). The same direction is returned for every measure.

    Parameters
    ----------
    points : (n_models, n_points, 3) array_like or sequence of (n_points_i, 3) array_like
        Point clouds in model coordinates, e.g. ``dataset[i]["points"]``;
        at least 3 points each.
    n_measures : int
        Copies of the direction per model, one per measure, at least 1
        (default: 4, the paper's measures).

    Returns
    -------
    directions : (n_models, n_measures, 3) float64
        Unit vectors, identical along the measure axis.

    Raises
    ------
    InputError
        On a wrong shape, fewer than 3 points, NaN or infinite coordinates,
        or a cloud whose points all coincide (naming ``points[i]``), or
        ``n_measures`` below 1.
    """
    n_measures = check_int(n_measures, "n_measures", minimum=1)
    if isinstance(points, np.ndarray):
        if points.ndim != 3 or points.shape[2] != 3:
            raise InputError("points: expected (n_models, n_points, 3) or a list of "
                             f"(n_points, 3) arrays, got shape {points.shape}")
        clouds: Sequence[ArrayLike] = list(points)
    else:
        clouds = list(points)  # type: ignore[arg-type]
    directions = np.zeros((len(clouds), n_measures, 3))
    for model, cloud in enumerate(clouds):
        try:
            array = np.asarray(cloud, dtype=np.float64)
        except (TypeError, ValueError) as err:
            raise InputError(f"points[{model}]: not a numeric array ({one_line(err)})") from err
        directions[model] = _pca_direction(array, f"points[{model}]")[None, :]
    return directions


def oracle_directions(dataset: ViewpointDataset) -> NDArray[np.float64]:
    """The dataset's own best sampled view of every model and measure.

    Scores 100 % under :func:`score_directions` by construction: an upper
    bound and a check of the evaluation itself.

    Parameters
    ----------
    dataset : ViewpointDataset
        A dataset or one split.

    Returns
    -------
    directions : (n_models, M, 3) float64
        ``dataset.views[dataset[i]["best_index"]]``, unit vectors, one per
        measure the dataset records, in its order.
    """
    directions = np.zeros((len(dataset), len(dataset.measures), 3))
    for model in range(len(dataset)):
        directions[model] = dataset.views[dataset[model]["best_index"]]
    return directions
