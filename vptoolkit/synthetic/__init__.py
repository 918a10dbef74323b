"""Procedural category-like meshes, a stand-in for the ModelNet40 subset of the paper.

Schelling et al. (EG 2021) train on the ModelNet40 categories airplane, bench,
bottle, car, chair, sofa, table and toilet, which we cannot ship. This module
builds shapes of those categories from primitives (blocks, surfaces of
revolution, tori) with random proportions and optional parts, so that the
dataset builder, the measures and the learning code can be exercised and
benchmarked end to end. The shapes are coarse, not realistic.

:func:`make_shape` builds one shape, deterministic per ``(category, seed)``;
:func:`write_collection` writes a ModelNet40-style folder tree of them. The
shapes are put together in two private modules: ``_parts`` (closed primitive
surfaces, their transforms and the assembly into one mesh) and
``_categories`` (one builder per category, drawing proportions and optional
parts from a generator).

Canonical frame (every category)
    ``+z`` is up, and the object stands on (or, for an airplane, rests near)
    the plane of lowest ``z``. ``+x`` is the front: the direction a person
    sitting on a chair, bench, sofa or toilet faces, and the nose of a car
    or an airplane. ``y`` runs left to right, and ``y = 0`` is the mirror
    plane. Bottles stand along the ``z`` axis. After assembly the bounding
    box is centred at the origin. Units are roughly metres (a bottle is
    about 0.2 tall, a car about 4 long), as scales in ModelNet40 vary too.

Symmetry
    Shapes of the categories in :data:`MIRROR_SYMMETRIC` are mirror symmetric
    across ``y = 0``: reflecting the vertices maps them onto vertices (up to
    rounding). The body of a bottle is also rotationally symmetric about the
    ``z`` axis, in steps of ``2 pi / 32``; an optional handle lies in the
    ``xz`` plane. Sofas with a chaise longue and toilets with a side flush
    lever are the asymmetric exceptions of their categories. This makes the
    label ambiguity between symmetric views real, as in ModelNet40.

Mesh properties
    One :class:`~vptoolkit.mesh.Mesh` concatenates all parts; parts may
    intersect each other, like in ModelNet40 (the cleaning step resolves
    that). Each part is a closed surface with outward, counter-clockwise
    faces; there are no degenerate faces, coordinates are finite and a shape
    has at most :data:`MAX_FACES` faces.

Randomness
    Each shape draws everything from one ``np.random.Generator(PCG64(s))``,
    where ``s`` comes from SHA-256 of the category and the seed, never from
    Python's ``hash()`` or global state.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vptoolkit.checks import check_int
from vptoolkit.errors import InputError
from vptoolkit.io import WRITABLE_SUFFIXES, save_mesh
from vptoolkit.mesh import Mesh
from vptoolkit.synthetic._categories import _BUILDERS
from vptoolkit.synthetic._parts import _assemble

__all__ = [
    "CATEGORIES",
    "LAYOUTS",
    "MAX_FACES",
    "MIRROR_SYMMETRIC",
    "make_shape",
    "write_collection",
]

CATEGORIES: tuple[str, ...] = (
    "airplane", "bench", "bottle", "car", "chair", "sofa", "table", "toilet",
)
"""The eight ModelNet40 categories of the paper, sorted."""

MIRROR_SYMMETRIC: tuple[str, ...] = ("airplane", "bench", "bottle", "car", "chair", "table")
"""Categories whose every shape is mirror symmetric across the plane ``y = 0``."""

MAX_FACES: int = 5000
"""Upper bound on the number of faces of any generated shape."""

LAYOUTS: tuple[str, ...] = ("modelnet", "flat")
"""Folder layouts of :func:`write_collection`."""


def make_shape(category: str, *, seed: int, name: str | None = None) -> Mesh:
    """Build one random shape of ``category``.

    Parameters
    ----------
    category : str
        One of :data:`CATEGORIES`.
    seed : int
        Any integer. The shape depends on ``(category, seed)`` only: the
        generator is ``PCG64`` seeded from SHA-256 of both.
    name : str, optional
        Name of the mesh (default: ``f"{category}_{seed:04d}"``, e.g.
        ``"chair_0007"``).

    Returns
    -------
    Mesh
        ``vertices : (n_vertices, 3) float64`` in the canonical frame of the
        module docstring (``+z`` up, ``+x`` front, bounding box centred at
        the origin); ``faces : (n_faces, 3) int64``, outward and
        counter-clockwise, at most :data:`MAX_FACES`.

    Raises
    ------
    InputError
        If ``category`` is not in :data:`CATEGORIES` or ``seed`` is not an int.

    Examples
    --------
    >>> chair = make_shape("chair", seed=7)
    >>> chair.name
    'chair_0007'
    """
    if not isinstance(category, str) or category not in _BUILDERS:
        raise InputError(
            f"category: unknown category {category!r}; expected one of {', '.join(CATEGORIES)}"
        )
    seed = check_int(seed, "seed")
    rng = np.random.Generator(np.random.PCG64(_stable_seed("vptoolkit.synthetic", category, seed)))
    parts = _BUILDERS[category](rng)
    return _assemble(parts, name=f"{category}_{seed:04d}" if name is None else name)


def write_collection(
    root: str | os.PathLike[str],
    *,
    n_per_category: int,
    categories: Sequence[str] = CATEGORIES,
    seed: int = 0,
    layout: str = "modelnet",
    test_fraction: float = 0.2,
    file_format: str = ".off",
) -> list[Path]:
    """Write a ModelNet40-style tree of synthetic shapes.

    Models are numbered from 1 per category, as in ModelNet40:
    ``<category>_0001`` ... ``<category>_<n_per_category>``. The last
    ``round(n_per_category * test_fraction)`` of them form the test split and
    the others the train split. Model ``i`` of a category is
    ``make_shape(category, seed=s_i)`` with ``s_i`` from SHA-256 of ``seed``
    and ``i``, so the tree depends on the arguments only, and adding models
    (a larger ``n_per_category``) never changes the existing ones (though it
    can move one from test to train).

    Parameters
    ----------
    root : str or os.PathLike
        Output folder, created if missing. Existing files of the same names
        are replaced; other files are left alone.
    n_per_category : int
        Number of models per category, at least 1.
    categories : sequence of str
        Categories to write, each from :data:`CATEGORIES` (default: all).
    seed : int
        Base seed of the collection (default: 0).
    layout : {"modelnet", "flat"}
        ``"modelnet"``: ``root/<category>/<train|test>/<category>_<NNNN><suffix>``;
        ``"flat"``: ``root/<category>/<category>_<NNNN><suffix>`` with no
        split folders (``test_fraction`` is then ignored). (default: "modelnet")
    test_fraction : float
        Fraction of each category in the test split, in ``[0, 1)``
        (default: 0.2).
    file_format : str
        Suffix of the files, one of :data:`vptoolkit.io.WRITABLE_SUFFIXES`
        (default: ".off", as in ModelNet40).

    Returns
    -------
    list of Path
        The files written, by category (in the given order) and then number.

    Raises
    ------
    InputError
        If an argument is invalid; the message names it.
    """
    category_list = _check_categories(categories)
    n_per_category = check_int(n_per_category, "n_per_category")
    if n_per_category < 1:
        raise InputError(f"n_per_category: expected an int >= 1, got {n_per_category}")
    seed = check_int(seed, "seed")
    if layout not in LAYOUTS:
        raise InputError(f"layout: expected one of {', '.join(LAYOUTS)}, got {layout!r}")
    is_number = isinstance(test_fraction, (int, float)) and not isinstance(test_fraction, bool)
    if not is_number or not 0.0 <= test_fraction < 1.0:
        raise InputError(f"test_fraction: expected a number in [0, 1), got {test_fraction!r}")
    suffix = file_format.lower() if isinstance(file_format, str) else ""
    if suffix not in WRITABLE_SUFFIXES:
        raise InputError(
            f"file_format: expected one of {', '.join(WRITABLE_SUFFIXES)}, got {file_format!r}"
        )
    try:
        root_path = Path(os.fspath(root))
    except TypeError as err:
        raise InputError(
            f"root: expected a str or os.PathLike, got {type(root).__name__}"
        ) from err

    n_test = int(round(n_per_category * test_fraction))
    written: list[Path] = []
    for category in category_list:
        for number in range(1, n_per_category + 1):
            name = f"{category}_{number:04d}"
            folder = root_path / category
            if layout == "modelnet":
                folder = folder / ("test" if number > n_per_category - n_test else "train")
            folder.mkdir(parents=True, exist_ok=True)
            model_seed = _stable_seed("vptoolkit.synthetic.collection", seed, number)
            mesh = make_shape(category, seed=model_seed, name=name)
            written.append(save_mesh(mesh, folder / f"{name}{suffix}"))
    return written


def _check_categories(categories: Sequence[str]) -> list[str]:
    """Return ``categories`` as a list after checking it is non-empty, known and unique."""
    if isinstance(categories, str):
        raise InputError(
            f"categories: expected a sequence of category names, got the string {categories!r}"
        )
    category_list = list(categories)
    unknown = [c for c in category_list if not isinstance(c, str) or c not in _BUILDERS]
    if unknown:
        raise InputError(
            f"categories: unknown {unknown!r}; expected some of {', '.join(CATEGORIES)}"
        )
    if not category_list or len(set(category_list)) != len(category_list):
        raise InputError(f"categories: expected distinct category names, got {category_list!r}")
    return category_list


def _stable_seed(*keys: object) -> int:
    """First 8 bytes of SHA-256 over the ``/``-joined keys, as a non-negative int."""
    digest = hashlib.sha256("/".join(str(key) for key in keys).encode("utf-8")).digest()
    return int.from_bytes(digest[:8], "big")
