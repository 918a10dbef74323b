"""Random rotations and per-model seeds, in numpy.

Everything that rotates a model (training augmentation, the rotated test
protocol of :mod:`vptoolkit.evaluate.protocol`) draws from here, so a model's rotations
depend only on a seed and the model's name, never on its position in a
dataset, a worker process or the global random state.

Rotations act on row vectors: ``rotated = v @ R.T``; a direction predicted on
a rotated input goes back to the model's frame with ``d @ R``.
"""

from __future__ import annotations

import hashlib

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import check_int
from vptoolkit.errors import InputError

__all__ = ["model_key", "random_rotation", "fixed_rotations"]

_SEED_PROTOCOL = 7  # keeps the protocol's rotations apart from the training augmentations


def model_key(name: str) -> int:
    """A stable 64-bit integer for a model name, used to seed its random draws.

    Returns
    -------
    key : int
        The first 8 bytes of ``SHA-256(name)`` (UTF-8) as a little-endian
        unsigned integer.
    """
    return int.from_bytes(hashlib.sha256(name.encode("utf-8")).digest()[:8], "little")


def random_rotation(rng: np.random.Generator) -> NDArray[np.float64]:
    """A rotation matrix drawn uniformly from SO(3).

    A quaternion with four independent standard normal components, scaled to
    unit length, is uniform on the 3-sphere, and the rotation it represents
    is uniform (Haar) on SO(3) (Shoemake 1992).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the four normal draws.

    Returns
    -------
    rotation : (3, 3) float64
        Orthonormal with determinant +1; rotate row vectors with
        ``v @ rotation.T``.
    """
    if not isinstance(rng, np.random.Generator):
        raise InputError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}")
    quaternion = rng.standard_normal(4)
    while np.linalg.norm(quaternion) < 1e-12:  # practically never
        quaternion = rng.standard_normal(4)
    w, x, y, z = quaternion / np.linalg.norm(quaternion)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def fixed_rotations(name: str, count: int, *, seed: int = 0) -> NDArray[np.float64]:
    """The evaluation rotations of one model: ``count`` uniform draws seeded by ``(seed, name)``.

    The same model always gets the same rotations, whichever split, order or
    program evaluates it, and the first ``k`` of ``count`` rotations do not
    depend on ``count``.

    Parameters
    ----------
    name : str
        Model name.
    count : int
        Number of rotations, at least 1.
    seed : int
        Base seed, non-negative (default: 0).

    Returns
    -------
    rotations : (count, 3, 3) float64
    """
    count = check_int(count, "count", minimum=1)
    seed = check_int(seed, "seed", minimum=0)
    rng = np.random.default_rng(
        np.random.SeedSequence([seed, _SEED_PROTOCOL, model_key(str(name))]))
    return np.stack([random_rotation(rng) for _ in range(count)])
