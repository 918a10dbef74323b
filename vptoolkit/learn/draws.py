"""The inputs a network reads of a model: which points, drawn how, seeded by what.

A model's points are put in a canonical order and keyed by their content
(:func:`content_order`: blind to order, position, scale, turn, file and
name); :func:`network_indices` then picks ``n_inputs`` inputs of a
checkpoint's input size, one farthest point sampling per model shared by
every input (as training draws from ``TrainOptions.fps_pool``) and a
random rest per input, from generators seeded by ``seed`` and that key.
So the same points get the same inputs wherever they appear, and a turned
copy the same inputs turned. :func:`network_inputs` gives the input
arrays (coordinates centred and scaled to unit size in float64, then any
point features), :func:`network_points` the first of them. numpy only:
:mod:`vptoolkit.learn.predict` asks the network.
"""

from __future__ import annotations

import hashlib
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import check_int_range
from vptoolkit.errors import InputError

__all__ = ["MAX_INPUTS", "N_INPUTS", "check_n_inputs", "content_order", "network_indices",
           "network_inputs", "network_points", "unit_size"]

N_INPUTS: Final = 16
"""Network inputs drawn per model, whose answers' consensus is the prediction.

Sixteen inputs bring the median angle between the answers for a model and for
a resampled, rotated copy of it to a few degrees on real meshes, and cost no
score (``docs/results.md``); where the answers still differ, most are views of
about the same quality, such as mirror images on a mirror-symmetric model.
"""

MAX_INPUTS: Final = 64
"""The most inputs a model may be asked about."""
_SEED_INPUT = 3


def content_order(points: NDArray[np.floating[Any]]) -> tuple[NDArray[np.int64], int]:
    """The canonical order of a point set and the key of its content, both blind to a turn.

    With ``c`` the mean of the points and ``r_i = |p_i - c|`` (float64), the
    order sorts the points by ``r_i``, ties by ``x``, then ``y``, then ``z``.
    The key is the first 128 bits of the BLAKE2b digest of the sorted radii
    divided by the largest and rounded to multiples of ``2^-20`` (as
    little-endian int64). Both stay the same when the points are reordered,
    moved, scaled, turned or mirrored, read from another file or format, or
    named otherwise, up to rounding: two points whose radii agree to about
    ``1e-15`` may swap places, and a radius within about ``1e-16`` of a
    rounding boundary changes the key, so a turned or reordered copy of a
    cloud of ``n`` points keeps its key and order but with a chance of about
    ``n * 1e-10``.

    Parameters
    ----------
    points : (n, 3) float
        Points, in any order.

    Returns
    -------
    order : (n,) int64
        The rows of ``points`` in canonical order.
    key : int
        The content key, a 128-bit non-negative integer.
    """
    cloud = np.asarray(points, dtype=np.float64)
    offsets = cloud - cloud.mean(axis=0)
    radii = np.sqrt(np.einsum("ij,ij->i", offsets, offsets))
    order = np.argsort(radii, kind="stable").astype(np.int64)
    if (np.diff(radii[order]) == 0.0).any():  # equal radii: their coordinates decide
        order = np.lexsort((cloud[:, 2], cloud[:, 1], cloud[:, 0], radii)).astype(np.int64)
    largest = float(radii.max(initial=0.0))
    relative = radii[order] / largest if largest > 0.0 else np.zeros(len(radii))
    rounded = np.round(relative * float(1 << 20)).astype("<i8")
    digest = hashlib.blake2b(rounded.tobytes(), digest_size=16).digest()
    return order, int.from_bytes(digest, "little")


def network_indices(points: NDArray[np.floating[Any]], *, n_points: int, n_fps: int,
                    seed: int, n_inputs: int = 1) -> NDArray[np.int64]:
    """Which surface points make each of a model's network inputs: a rule of its points alone.

    The points are put in their canonical order (:func:`content_order`) and
    one ``SeedSequence([seed, 3, key])`` of their content key is split
    (:meth:`numpy.random.SeedSequence.spawn`): its child 0 starts one
    farthest point sampling of ``n_fps`` points, which every input holds (as
    training draws inputs from a few farthest-point subsets per model,
    ``TrainOptions.fps_pool``), and child ``k + 1`` draws the other
    ``n_points - n_fps`` points of input ``k``
    (:func:`vptoolkit.points.network_input_indices`). So the inputs depend on
    the points and ``seed`` only, never on the model's name, the file, its
    format or the order of the points; the inputs of a turned copy of the
    points are the same points turned, so a network that turns its answer
    with its input (the canonical input frame, :mod:`vptoolkit.learn.frame`)
    answers the turned copy with its answer turned. Input ``k`` is the same
    whatever ``n_inputs``.

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    n_points, n_fps : int
        Input size and its farthest-point part (``n_fps`` is capped at ``n``).
    seed : int
        Base seed.
    n_inputs : int
        How many inputs, 1 to 64 (default: 1).

    Returns
    -------
    indices : (n_inputs, n_points) int64
        Rows of ``points``: the farthest-point picks in picking order, then
        the random ones.
    """
    from vptoolkit.points import farthest_point_sampling, network_input_indices

    n_inputs = check_n_inputs(n_inputs)
    order, key = content_order(points)
    canonical = np.asarray(points, dtype=np.float64)[order]
    fps_sequence, *draws = np.random.SeedSequence([int(seed), _SEED_INPUT, key]).spawn(
        1 + n_inputs)
    n_fps = min(n_fps, len(canonical))
    fps = (farthest_point_sampling(canonical, n_fps, rng=np.random.default_rng(fps_sequence))
           if n_fps else np.zeros(0, dtype=np.int64))
    return np.stack([order[network_input_indices(canonical, n_points, n_fps,
                                                 rng=np.random.default_rng(draw),
                                                 fps_indices=fps)]
                     for draw in draws])


def network_points(points: NDArray[np.floating[Any]], *, n_points: int, n_fps: int,
                   seed: int, name: str) -> NDArray[np.float32]:
    """The first network input of a sampled surface: ``network_inputs(..., n_inputs=1)[0]``.

    Parameters are those of :func:`network_inputs`.

    Returns
    -------
    input_points : (n_points, 3) float32
        Centred and scaled as :func:`network_inputs` says.
    """
    return network_inputs(points, n_points=n_points, n_fps=n_fps, seed=seed, name=name,
                          n_inputs=1)[0]


def network_inputs(points: NDArray[np.floating[Any]], *, n_points: int, n_fps: int,
                   seed: int, name: str, n_inputs: int = N_INPUTS,
                   features: NDArray[np.floating[Any]] | None = None) -> NDArray[np.float32]:
    """The ``n_inputs`` network inputs of one model (:func:`network_indices`).

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    n_points, n_fps, seed
        As for :func:`network_indices`.
    name : str
        The model's name, for messages (it never changes the inputs).
    n_inputs : int
        How many inputs, 1 to 64 (default: :data:`N_INPUTS`).
    features : (n, F) float, optional
        Point features of ``points`` (:mod:`vptoolkit.point_features`), put
        after the coordinates of each chosen point.

    Returns
    -------
    inputs : (n_inputs, n_points, 3 + F) float32
        Input ``k`` holds the points of row ``k`` of :func:`network_indices`,
        their coordinates centred on the bounding-box centre of ``points`` and
        divided by its diagonal in float64 before the cast to float32, so a model
        of any size float64 holds gets the same input (the network is blind to
        position and size; float32 alone would lose a model below about
        ``1e-30`` or above ``1e19`` in its frame and normalisation).
    """
    cloud = unit_size(np.asarray(points, dtype=np.float64), name)
    if features is not None:
        features = np.asarray(features)
        if features.ndim != 2 or len(features) != len(cloud):
            raise InputError(f"{name}: features: expected ({len(cloud)}, F) for {len(cloud)} "
                             f"points, got shape {features.shape}")
        cloud = np.concatenate([cloud, features], axis=1)
    chosen = network_indices(points, n_points=n_points, n_fps=n_fps, seed=seed,
                             n_inputs=n_inputs)
    return cloud[chosen].astype(np.float32)


def unit_size(points: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    """``(points - c) / d`` for the bounding box's centre ``c`` and diagonal ``d`` (``d > 0``).

    The diagonal is taken as ``m * |span / m|`` with ``m`` the largest side, which
    neither overflows nor underflows for any finite float64 coordinates.
    """
    if points.ndim != 2 or points.shape[1] != 3 or len(points) == 0:
        raise InputError(f"{name}: points: expected shape (n, 3) with n >= 1, got {points.shape}")
    if not np.isfinite(points).all():
        raise InputError(f"{name}: points: not all coordinates are finite")
    low, high = points.min(axis=0), points.max(axis=0)
    centre = low / 2.0 + high / 2.0
    span = high / 2.0 - low / 2.0  # halves: the difference of huge values stays finite
    largest = float(span.max())
    if largest <= 0.0:
        return points - centre
    return (points - centre) / (2.0 * largest * float(np.linalg.norm(span / largest)))


def check_n_inputs(n_inputs: Any) -> int:
    return check_int_range(n_inputs, "n_inputs", 1, MAX_INPUTS)
