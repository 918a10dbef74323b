"""Procedural category-like meshes, a stand-in for the ModelNet40 subset of the paper.

Schelling et al. (EG 2021) train on the ModelNet40 categories airplane, bench,
bottle, car, chair, sofa, table and toilet, which we cannot ship. This module
builds shapes of those categories from primitives (blocks, surfaces of
revolution, tori) with random proportions and optional parts, so that the
dataset builder, the measures and the learning code can be exercised and
benchmarked end to end. The shapes are coarse, not realistic.

:func:`make_shape` builds one shape, deterministic per ``(category, seed)``;
:func:`write_collection` writes a ModelNet40-style folder tree of them.

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
import math
import os
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import check_int
from vptoolkit.errors import InputError
from vptoolkit.io import WRITABLE_SUFFIXES, save_mesh
from vptoolkit.mesh import Mesh

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

# A part is a closed triangle surface: (n, 3) float64 vertices, (m, 3) int64 faces.
_Part = tuple[NDArray[np.float64], NDArray[np.int64]]

_SEGMENTS = 24
"""Default number of segments around a surface of revolution (even: mirror symmetric)."""


# ============================================================================ public API


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


# ============================================================================ primitives
#
# Each primitive returns a closed surface with outward counter-clockwise faces.
# Transforms use proper rotations and positive scales only (they keep the
# winding); _mirrored reflects across y = 0 and reverses the winding.

# Faces of a block with corners numbered like the unit cube's, see _block.
_BLOCK_FACES = np.array(
    [
        [0, 3, 2], [0, 2, 1],  # bottom (-z)
        [4, 5, 6], [4, 6, 7],  # top (+z)
        [0, 1, 5], [0, 5, 4],  # -y
        [1, 2, 6], [1, 6, 5],  # +x
        [2, 3, 7], [2, 7, 6],  # +y
        [3, 0, 4], [3, 4, 7],  # -x
    ],
    dtype=np.int64,
)


def _block(corners: ArrayLike) -> _Part:
    """A hexahedron (12 triangles) from 8 corners.

    Parameters
    ----------
    corners : (8, 3) float
        Numbered like the unit cube's ``(x, y, z)`` corners: bottom ``(0,0,0),
        (1,0,0), (1,1,0), (0,1,0)``, then the top in the same order. Any
        non-inverted deformation of that cube (tapered wing, slanted panel)
        gives outward faces.
    """
    return np.asarray(corners, dtype=np.float64).reshape(8, 3), _BLOCK_FACES.copy()


def _box(low: ArrayLike, high: ArrayLike) -> _Part:
    """An axis-aligned box between the corners ``low`` and ``high``, each (3,) float."""
    x0, y0, z0 = np.asarray(low, dtype=np.float64)
    x1, y1, z1 = np.asarray(high, dtype=np.float64)
    return _block([
        [x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
        [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1],
    ])


def _centred_box(centre: ArrayLike, size: ArrayLike) -> _Part:
    """An axis-aligned box of ``size`` (3,) around ``centre`` (3,)."""
    middle = np.asarray(centre, dtype=np.float64)
    half = np.asarray(size, dtype=np.float64) / 2.0
    return _box(middle - half, middle + half)


def _revolve(
    profile: ArrayLike, *, n_segments: int = _SEGMENTS, is_loop: bool = False
) -> _Part:
    """A surface of revolution about the ``z`` axis.

    Parameters
    ----------
    profile : (n_points, 2) float
        ``(radius, z)`` points. An open profile runs from bottom to top with
        the solid on the side of the axis; an end with radius 0 becomes a
        pole and an end with radius > 0 is closed by a flat cap. A loop
        (``is_loop``) runs counter-clockwise in the ``(radius, z)`` plane with
        all radii > 0 (a torus). Consecutive points must differ.
    n_segments : int
        Points per ring, even so that the surface is mirror symmetric across
        ``y = 0`` (ring angles ``2 pi j / n_segments``, starting on ``+x``).
    is_loop : bool
        Whether the profile is closed (default: False).
    """
    points = np.asarray(profile, dtype=np.float64)
    if not is_loop:
        if points[0, 0] > 0:
            points = np.vstack([[0.0, points[0, 1]], points])
        if points[-1, 0] > 0:
            points = np.vstack([points, [0.0, points[-1, 1]]])
        rings = points[1:-1]
    else:
        rings = points
    angles = 2.0 * np.pi * np.arange(n_segments) / n_segments
    n_rings = len(rings)
    ring_xyz = np.stack([
        np.outer(rings[:, 0], np.cos(angles)),
        np.outer(rings[:, 0], np.sin(angles)),
        np.repeat(rings[:, 1:2], n_segments, axis=1),
    ], axis=-1).reshape(-1, 3)

    j = np.arange(n_segments)
    j_next = (j + 1) % n_segments
    faces: list[NDArray[np.int64]] = []
    offset = 0 if is_loop else 1  # the bottom pole is vertex 0
    ring_pairs = [(i, (i + 1) % n_rings) for i in range(n_rings if is_loop else n_rings - 1)]
    for lower, upper in ring_pairs:
        a = offset + lower * n_segments + j
        b = offset + lower * n_segments + j_next
        c = offset + upper * n_segments + j_next
        d = offset + upper * n_segments + j
        faces += [np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)]
    if is_loop:
        return ring_xyz, np.concatenate(faces).astype(np.int64)

    top = 1 + n_rings * n_segments
    first, last = 1 + j, 1 + (n_rings - 1) * n_segments + j
    first_next, last_next = 1 + j_next, 1 + (n_rings - 1) * n_segments + j_next
    faces.append(np.stack([np.zeros_like(j), first_next, first], axis=1))
    faces.append(np.stack([last, last_next, np.full_like(j, top)], axis=1))
    vertices = np.vstack([[0.0, 0.0, points[0, 1]], ring_xyz, [0.0, 0.0, points[-1, 1]]])
    return vertices, np.concatenate(faces).astype(np.int64)


def _cylinder(radius: float, z0: float, z1: float, *, n_segments: int = _SEGMENTS) -> _Part:
    """A capped cylinder along ``z`` from ``z0`` to ``z1`` (``z0 < z1``)."""
    return _revolve([[radius, z0], [radius, z1]], n_segments=n_segments)


def _frustum(
    r0: float, r1: float, z0: float, z1: float, *, n_segments: int = _SEGMENTS
) -> _Part:
    """A capped cone frustum along ``z``: radius ``r0`` at ``z0``, ``r1`` at ``z1``."""
    return _revolve([[r0, z0], [r1, z1]], n_segments=n_segments)


def _sphere(radius: float, *, n_segments: int = 16) -> _Part:
    """A UV sphere about the origin with ``n_segments // 2`` bands from pole to pole."""
    theta = np.linspace(-np.pi / 2, np.pi / 2, n_segments // 2 + 1)
    profile = np.stack([radius * np.cos(theta), radius * np.sin(theta)], axis=1)
    profile[[0, -1], 0] = 0.0  # exact poles
    return _revolve(profile, n_segments=n_segments)


def _torus(major: float, minor: float, *, n_major: int = _SEGMENTS, n_minor: int = 10) -> _Part:
    """A torus about the ``z`` axis, centred at the origin (``major > minor``)."""
    phi = 2.0 * np.pi * np.arange(n_minor) / n_minor
    loop = np.stack([major + minor * np.cos(phi), minor * np.sin(phi)], axis=1)
    return _revolve(loop, n_segments=n_major, is_loop=True)


def _rotation(axis: str, angle: float) -> NDArray[np.float64]:
    """Right-handed rotation (3, 3) by ``angle`` radians about ``"x"``, ``"y"`` or ``"z"``."""
    c, s = math.cos(angle), math.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=np.float64)
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], dtype=np.float64)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=np.float64)


# Rotations taking a primitive built along z onto the other axes.
_Z_TO_X = _rotation("y", np.pi / 2)
_Z_TO_Y = _rotation("x", -np.pi / 2)


def _moved(
    part: _Part,
    *,
    scale: ArrayLike = 1.0,
    rotation: NDArray[np.float64] | None = None,
    offset: ArrayLike = 0.0,
) -> _Part:
    """Scale (positive, per axis), then rotate (proper), then translate a part."""
    vertices, faces = part
    vertices = vertices * np.asarray(scale, dtype=np.float64)
    if rotation is not None:
        vertices = vertices @ rotation.T
    return vertices + np.asarray(offset, dtype=np.float64), faces


def _mirrored(part: _Part) -> _Part:
    """The reflection of a part across ``y = 0``, with the winding reversed to stay outward."""
    vertices, faces = part
    return vertices * np.array([1.0, -1.0, 1.0]), faces[:, ::-1].copy()


def _pair(part: _Part) -> list[_Part]:
    """A part and its mirror image across ``y = 0``."""
    return [part, _mirrored(part)]


def _rod(start: ArrayLike, end: ArrayLike, radius: float, *, n_segments: int = 12) -> _Part:
    """A capped cylinder from ``start`` to ``end`` (each (3,) float)."""
    start, end = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    axis = end - start
    length = float(np.linalg.norm(axis))
    return _moved(_cylinder(radius, 0.0, length, n_segments=n_segments),
                  rotation=_align_z(axis / length), offset=start)


def _align_z(direction: NDArray[np.float64]) -> NDArray[np.float64]:
    """The rotation (3, 3) about ``z x direction`` taking ``+z`` onto the unit ``direction``."""
    cross = np.cross([0.0, 0.0, 1.0], direction)
    sin, cos = float(np.linalg.norm(cross)), float(direction[2])
    if sin < 1e-12:
        return np.eye(3) if cos > 0 else _rotation("x", np.pi)
    k = cross / sin
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + sin * skew + (1.0 - cos) * skew @ skew


def _assemble(parts: Iterable[_Part], *, name: str) -> Mesh:
    """Concatenate parts into one Mesh with its bounding box centred at the origin."""
    vertex_blocks: list[NDArray[np.float64]] = []
    face_blocks: list[NDArray[np.int64]] = []
    n_vertices = 0
    for vertices, faces in parts:
        vertex_blocks.append(vertices)
        face_blocks.append(faces + n_vertices)
        n_vertices += len(vertices)
    vertices = np.vstack(vertex_blocks)
    vertices = vertices - (vertices.min(axis=0) + vertices.max(axis=0)) / 2.0
    return Mesh(vertices, np.vstack(face_blocks).astype(np.int64), name)


def _pick(rng: np.random.Generator, options: Sequence[str], weights: Sequence[float]) -> str:
    """One of ``options`` drawn with probabilities ``weights`` (summing to 1)."""
    return options[int(rng.choice(len(options), p=weights))]


# ============================================================================ categories
#
# One builder per category: rng -> list of parts, in the canonical frame
# (+z up, +x front, mirror plane y = 0, floor at z = 0 before centring).


def _wing(
    *, x_root: float, z_root: float, chord: float, span: float, taper: float,
    sweep: float, dihedral: float, thickness: float,
) -> _Part:
    """The right (``+y``) half of a straight tapered wing as one block.

    The root lies in ``y = 0`` with its trailing edge at ``x_root`` and its
    leading edge at ``x_root + chord``; the leading edge is swept back
    (towards ``-x``) by ``sweep`` radians and the tip raised by ``dihedral``
    radians. Chord and thickness shrink by the factor ``taper`` at the tip.
    """
    tip_chord, tip_t = chord * taper, thickness * taper
    tip_x = x_root + chord - span * math.tan(sweep) - tip_chord  # trailing edge at the tip
    tip_z = z_root + span * math.tan(dihedral)
    root_low, root_high = z_root - thickness / 2, z_root + thickness / 2
    tip_low, tip_high = tip_z - tip_t / 2, tip_z + tip_t / 2
    return _block([
        [x_root, 0.0, root_low], [x_root + chord, 0.0, root_low],
        [tip_x + tip_chord, span, tip_low], [tip_x, span, tip_low],
        [x_root, 0.0, root_high], [x_root + chord, 0.0, root_high],
        [tip_x + tip_chord, span, tip_high], [tip_x, span, tip_high],
    ])


def _airplane(rng: np.random.Generator) -> list[_Part]:
    """Fuselage of revolution, swept wings, 0/2/4 engines, usually a tail fin, maybe a T-tail."""
    length = rng.uniform(12.0, 40.0)
    radius = length * rng.uniform(0.04, 0.065)
    # Fuselage profile from the tail (z = 0) to the nose (z = length), turned onto +x.
    tail_end, nose_start = length * rng.uniform(0.2, 0.3), length * rng.uniform(0.8, 0.88)
    nose = np.linspace(0.0, np.pi / 2, 6)[1:]
    profile = np.vstack([
        [[radius * 0.12, 0.0], [radius * 0.45, tail_end * 0.4], [radius * 0.85, tail_end * 0.8],
         [radius, tail_end], [radius, nose_start]],
        np.stack([radius * np.cos(nose), nose_start + (length - nose_start) * np.sin(nose)], 1),
    ])
    profile[-1, 0] = 0.0  # the nose is a pole
    fuselage = _revolve(profile, n_segments=20)
    parts = [_moved(fuselage, rotation=_Z_TO_X, offset=[-length / 2, 0.0, 0.0])]

    half_span, chord = length * rng.uniform(0.4, 0.65), length * rng.uniform(0.12, 0.22)
    taper, sweep = rng.uniform(0.25, 0.6), math.radians(rng.uniform(0.0, 35.0))
    dihedral = math.radians(rng.uniform(0.0, 6.0))
    wing_x = length * rng.uniform(-0.12, 0.02) - chord / 2
    wing_z = radius * float(rng.choice([-0.6, 0.0, 0.7], p=[0.6, 0.2, 0.2]))  # low, mid, high
    parts += _pair(_wing(x_root=wing_x, z_root=wing_z, chord=chord, span=half_span, taper=taper,
                         sweep=sweep, dihedral=dihedral, thickness=chord * 0.12))

    # Engines: 0, 2 or 4 nacelles hanging on pylons in front of the wing.
    n_engines = int(rng.choice([0, 2, 4], p=[0.25, 0.5, 0.25]))
    nacelle_r, nacelle_len = radius * rng.uniform(0.35, 0.55), chord * rng.uniform(0.7, 1.0)
    nacelle = _revolve([
        [nacelle_r * 0.6, 0.0], [nacelle_r, nacelle_len * 0.25],
        [nacelle_r * 0.95, nacelle_len * 0.85], [nacelle_r * 0.75, nacelle_len],
    ], n_segments=16)
    nacelle = _moved(nacelle, rotation=_Z_TO_X)
    for fraction in {0: [], 2: [0.35], 4: [0.3, 0.6]}[n_engines]:
        y = half_span * fraction
        leading_x = wing_x + chord - y * math.tan(sweep)
        z = wing_z + y * math.tan(dihedral) - nacelle_r * 1.6
        parts += _pair(_moved(nacelle, offset=[leading_x - nacelle_len * 0.45, y, z]))
        parts += _pair(_centred_box([leading_x - nacelle_len * 0.15, y, z + nacelle_r],
                                    [nacelle_len * 0.5, nacelle_r * 0.25, nacelle_r * 1.6]))

    # Tail: a swept vertical fin (most airplanes), stabilisers low or on top of the fin.
    fin_x = -length / 2 + length * rng.uniform(0.01, 0.05)  # trailing edge of the fin root
    fin_chord, fin_height = length * rng.uniform(0.12, 0.2), radius * rng.uniform(2.0, 3.5)
    fin_taper = rng.uniform(0.35, 0.7)
    fin_tip_x = fin_x + fin_chord * (1.0 - fin_taper) * rng.uniform(0.2, 1.3)  # tip trailing edge
    fin_tip_chord = fin_chord * fin_taper
    has_fin = rng.random() < 0.85
    if has_fin:
        t = fin_chord * 0.1
        parts.append(_block([
            [fin_x, -t / 2, 0.0], [fin_x + fin_chord, -t / 2, 0.0],
            [fin_x + fin_chord, t / 2, 0.0], [fin_x, t / 2, 0.0],
            [fin_tip_x, -t / 4, fin_height], [fin_tip_x + fin_tip_chord, -t / 4, fin_height],
            [fin_tip_x + fin_tip_chord, t / 4, fin_height], [fin_tip_x, t / 4, fin_height],
        ]))
    is_t_tail = has_fin and rng.random() < 0.2
    stab_chord = fin_chord * rng.uniform(0.7, 1.0) * (fin_taper if is_t_tail else 1.0)
    parts += _pair(_wing(
        x_root=fin_tip_x if is_t_tail else fin_x,
        z_root=fin_height if is_t_tail else radius * rng.uniform(-0.1, 0.4),
        chord=stab_chord, span=half_span * rng.uniform(0.28, 0.4), taper=rng.uniform(0.4, 0.7),
        sweep=sweep, dihedral=dihedral, thickness=stab_chord * 0.1,
    ))
    return parts


def _bench(rng: np.random.Generator) -> list[_Part]:
    """Long low seat (slab or slats) on legs, end panels or A-frames, maybe a backrest and arms."""
    length, depth = rng.uniform(1.2, 2.2), rng.uniform(0.32, 0.5)
    seat_z, thickness = rng.uniform(0.4, 0.48), rng.uniform(0.04, 0.07)
    under, half_y = seat_z - thickness, length / 2
    parts: list[_Part] = []
    if rng.random() < 0.5:
        parts.append(_box([-depth / 2, -half_y, under], [depth / 2, half_y, seat_z]))
    else:
        n_slats = int(rng.integers(3, 6))
        gap = depth * rng.uniform(0.03, 0.08)
        slat = (depth - (n_slats - 1) * gap) / n_slats
        for k in range(n_slats):
            x0 = -depth / 2 + k * (slat + gap)
            parts.append(_box([x0, -half_y, under], [x0 + slat, half_y, seat_z]))

    end_y = half_y - rng.uniform(0.03, 0.15)  # outer face of the supports at either end
    support = _pick(rng, ["legs", "panels", "a_frame"], [0.45, 0.3, 0.25])
    if support == "legs":  # four legs, six on long benches
        leg = rng.uniform(0.04, 0.07)
        leg_x = depth / 2 - leg / 2 - rng.uniform(0.0, 0.05)
        for x in (-leg_x, leg_x):
            parts += _pair(_centred_box([x, end_y - leg / 2, under / 2], [leg, leg, under]))
            if length > 1.7:
                parts.append(_centred_box([x, 0.0, under / 2], [leg, leg, under]))
    elif support == "panels":
        panel = rng.uniform(0.04, 0.08)
        parts += _pair(_box([-depth * 0.45, end_y - panel, 0.0], [depth * 0.45, end_y, under]))
    else:  # an A-frame of two slanted bars at each end, with a cross bar
        bar, splay = rng.uniform(0.04, 0.06), rng.uniform(0.0, 0.08)
        for side in (-1.0, 1.0):
            foot, head = side * (depth / 2 + splay - bar), side * depth / 4
            foot_low, foot_high = sorted([foot, foot + side * bar])
            head_low, head_high = sorted([head, head + side * bar])
            parts += _pair(_block([
                [foot_low, end_y - bar, 0.0], [foot_high, end_y - bar, 0.0],
                [foot_high, end_y, 0.0], [foot_low, end_y, 0.0],
                [head_low, end_y - bar, under], [head_high, end_y - bar, under],
                [head_high, end_y, under], [head_low, end_y, under],
            ]))
        parts += _pair(_centred_box([0.0, end_y - bar / 2, under * 0.35], [depth * 0.8, bar, bar]))

    if rng.random() < 0.35:  # a backrest: two tilted posts and 1-3 rails
        back_h, post = rng.uniform(0.3, 0.42), rng.uniform(0.04, 0.06)
        tilt = _rotation("y", -math.radians(rng.uniform(0.0, 15.0)))
        back_x = -depth / 2 + post / 2
        post_part = _centred_box([0.0, 0.0, back_h / 2], [post, post, back_h])
        parts += _pair(_moved(post_part, rotation=tilt, offset=[back_x, end_y - post / 2, seat_z]))
        n_rails = int(rng.integers(1, 4))
        rail_h = back_h * 0.7 / n_rails
        for k in range(n_rails):
            z_mid = back_h * 0.85 - k * back_h * 0.8 / n_rails - rail_h / 2
            rail = _centred_box([0.0, 0.0, z_mid], [post * 0.6, length * 0.98, rail_h * 0.8])
            parts.append(_moved(rail, rotation=tilt, offset=[back_x, 0.0, seat_z]))
        if rng.random() < 0.5:  # armrests: a post and a rest at each end
            arm_h, arm_y = rng.uniform(0.18, 0.25), half_y - 0.03
            parts += _pair(_centred_box([depth * 0.3, arm_y, seat_z + arm_h / 2],
                                        [0.04, 0.04, arm_h]))
            parts += _pair(_centred_box([0.0, arm_y, seat_z + arm_h], [depth * 0.9, 0.06, 0.035]))
    return parts


def _bottle(rng: np.random.Generator) -> list[_Part]:
    """One surface of revolution (body, shoulder, neck, lip, maybe a cap), maybe a handle."""
    radius = rng.uniform(0.03, 0.055)
    body_h = radius * rng.uniform(3.0, 5.5)
    shoulder_h = radius * rng.uniform(0.4, 1.6)
    neck_r = radius * rng.uniform(0.22, 0.45)
    neck_h = radius * rng.uniform(0.6, 2.6)
    waist = rng.uniform(0.82, 0.95) if rng.random() < 0.3 else 1.0
    body_z = np.linspace(0.08 * radius, body_h, 5)
    body_r = radius * (1.0 - (1.0 - waist) * np.sin(np.linspace(0.0, np.pi, 5)))
    t = np.linspace(0.0, 1.0, 9)[1:]
    shoulder_r = neck_r + (radius - neck_r) * (1 + np.cos(np.pi * t)) / 2
    top, lip, lip_r = body_h + shoulder_h + neck_h, radius * 0.08, neck_r * 1.18
    profile = [
        [[radius * 0.9, 0.0]],  # a chamfered bottom edge
        np.stack([body_r, body_z], axis=1),
        np.stack([shoulder_r, body_h + shoulder_h * t], axis=1),
        [[neck_r, top - lip], [lip_r, top - lip], [lip_r, top - lip * 0.3], [neck_r, top]],
    ]
    if rng.random() < 0.4:  # a screw cap on top of the neck
        cap_r, cap_h = neck_r * rng.uniform(1.1, 1.3), radius * rng.uniform(0.3, 0.8)
        profile.append([[cap_r, top], [cap_r, top + cap_h]])
    parts = [_revolve(np.vstack(profile), n_segments=32)]
    if rng.random() < 0.2:  # an upright oval handle in the xz plane, half inside the body
        major, minor = radius * rng.uniform(0.4, 0.55), radius * rng.uniform(0.1, 0.16)
        stretch = rng.uniform(1.4, 2.2)  # taller than wide
        handle_z = body_h * rng.uniform(0.5, 0.7)
        parts.append(_moved(_torus(major, minor, n_major=20, n_minor=8), scale=[1.0, stretch, 1.0],
                            rotation=_rotation("x", np.pi / 2), offset=[radius, 0.0, handle_z]))
    return parts


def _car(rng: np.random.Generator) -> list[_Part]:
    """Slanted lower body, tapered cabin by body type, four wheels, maybe mirrors and spoiler."""
    kind = _pick(rng, ["sedan", "hatchback", "suv", "pickup", "coupe"],
                 [0.3, 0.2, 0.2, 0.15, 0.15])
    is_tall = kind in ("suv", "pickup")
    length, width = rng.uniform(3.6, 5.0), rng.uniform(1.65, 2.0)
    wheel_r = rng.uniform(0.3, 0.38) * (1.15 if is_tall else 1.0)
    clearance = wheel_r * rng.uniform(0.45, 0.65)
    belt = clearance + rng.uniform(0.5, 0.65) * (1.15 if is_tall else 1.0)
    roof = belt + rng.uniform(0.4, 0.55) * (0.85 if kind == "coupe" else 1.0)
    x0, x1, y = -length / 2, length / 2, width / 2
    nose, tail = length * rng.uniform(0.03, 0.07), length * rng.uniform(0.02, 0.05)
    parts = [_block([
        [x0 + tail, -y, clearance], [x1 - nose, -y, clearance],
        [x1 - nose, y, clearance], [x0 + tail, y, clearance],
        [x0, -y, belt], [x1, -y, belt], [x1, y, belt], [x0, y, belt],
    ])]
    # Cabin: from cabin_x0 to cabin_x1 at the belt line, the narrower roof set back at both ends.
    front = {"sedan": 0.3, "hatchback": 0.25, "suv": 0.27, "pickup": 0.3, "coupe": 0.25}[kind]
    rear = {"sedan": 0.22, "hatchback": 0.02, "suv": 0.02, "pickup": 0.45, "coupe": 0.2}[kind]
    cabin_x1 = x1 - length * (front + rng.uniform(-0.03, 0.03))
    cabin_x0 = x0 + length * (rear + rng.uniform(0.0, 0.03))
    cabin_len = cabin_x1 - cabin_x0
    roof_x1 = cabin_x1 - cabin_len * rng.uniform(0.22, 0.35)  # windscreen slope
    rear_slope = rng.uniform(0.02, 0.08) if kind in ("hatchback", "suv", "pickup") \
        else rng.uniform(0.15, 0.3)
    roof_x0 = cabin_x0 + cabin_len * rear_slope
    cabin_y, roof_y = y * 0.97, y * rng.uniform(0.78, 0.9)
    parts.append(_block([
        [cabin_x0, -cabin_y, belt], [cabin_x1, -cabin_y, belt],
        [cabin_x1, cabin_y, belt], [cabin_x0, cabin_y, belt],
        [roof_x0, -roof_y, roof], [roof_x1, -roof_y, roof],
        [roof_x1, roof_y, roof], [roof_x0, roof_y, roof],
    ]))
    # Wheels: tyres with rounded edges, axis along y, mirrored across y = 0.
    tyre_w = rng.uniform(0.18, 0.26)
    tyre = [[wheel_r * 0.7, -tyre_w / 2], [wheel_r * 0.95, -tyre_w / 2],
            [wheel_r, -tyre_w * 0.3], [wheel_r, tyre_w * 0.3],
            [wheel_r * 0.95, tyre_w / 2], [wheel_r * 0.7, tyre_w / 2]]
    wheel = _moved(_revolve(tyre, n_segments=20), rotation=_Z_TO_Y)
    wheel_front = x1 - length * rng.uniform(0.17, 0.23)
    wheel_rear = x0 + length * rng.uniform(0.17, 0.25)
    for x in (wheel_front, wheel_rear):
        parts += _pair(_moved(wheel, offset=[x, y - tyre_w * 0.4, wheel_r]))
    if rng.random() < 0.6:  # side mirrors
        parts += _pair(_centred_box([cabin_x1 - 0.1, y + 0.06, belt + 0.12], [0.1, 0.14, 0.1]))
    if kind != "pickup" and rng.random() < 0.25:  # a rear spoiler on two posts
        spoiler_z = belt + rng.uniform(0.12, 0.25)
        parts.append(_box([x0 + 0.02, -y * 0.85, spoiler_z],
                          [x0 + 0.3, y * 0.85, spoiler_z + 0.04]))
        parts += _pair(_centred_box([x0 + 0.16, y * 0.6, (belt + spoiler_z) / 2 + 0.01],
                                    [0.08, 0.05, spoiler_z - belt + 0.02]))
    if kind == "suv" and rng.random() < 0.5:  # roof rails
        parts += _pair(_box([roof_x0 + 0.05, roof_y * 0.8, roof],
                            [roof_x1 - 0.05, roof_y * 0.9, roof + 0.06]))
    return parts


def _chair(rng: np.random.Generator) -> list[_Part]:
    """Seat on four legs, swivel base or sled; solid, slatted or framed back; maybe arms."""
    seat_z, thickness = rng.uniform(0.4, 0.5), rng.uniform(0.03, 0.08)
    width, depth = rng.uniform(0.4, 0.56), rng.uniform(0.38, 0.52)
    under = seat_z - thickness
    parts = [_box([-depth / 2, -width / 2, under], [depth / 2, width / 2, seat_z])]
    base = _pick(rng, ["legs", "swivel", "sled"], [0.65, 0.25, 0.1])
    if base == "legs":
        leg, inset = rng.uniform(0.025, 0.05), rng.uniform(0.0, 0.04)
        leg_x, leg_y = depth / 2 - inset - leg / 2, width / 2 - inset - leg / 2
        if rng.random() < 0.4:  # round legs, maybe tapered towards the floor
            leg_part = _frustum(leg / 2 * rng.uniform(0.6, 1.0), leg / 2, 0.0, under, n_segments=12)
        else:
            leg_part = _centred_box([0.0, 0.0, under / 2], [leg, leg, under])
        for x in (-leg_x, leg_x):
            parts += _pair(_moved(leg_part, offset=[x, leg_y, 0.0]))
        if rng.random() < 0.4:  # side stretchers
            stretcher = _centred_box([0.0, leg_y, under * 0.3], [2 * leg_x, leg * 0.6, leg * 0.6])
            parts += _pair(stretcher)
    elif base == "swivel":  # gas column, hub, five spokes with casters
        column_r = rng.uniform(0.022, 0.035)
        hub_z, spoke_len = rng.uniform(0.06, 0.1), rng.uniform(0.24, 0.32)
        parts.append(_cylinder(column_r, hub_z, under))
        parts.append(_cylinder(column_r * 1.8, hub_z - 0.03, hub_z + 0.03))
        spoke = _box([0.0, -0.02, hub_z - 0.02], [spoke_len, 0.02, hub_z + 0.02])
        caster = _moved(_sphere(0.025, n_segments=12), offset=[spoke_len - 0.02, 0.0, 0.025])
        for k in range(5):
            turn = _rotation("z", 2 * np.pi * k / 5)
            parts += [_moved(spoke, rotation=turn), _moved(caster, rotation=turn)]
    else:  # sled: a runner on the floor and two uprights on each side
        bar = rng.uniform(0.015, 0.025)
        runner_y = width / 2 - bar
        parts += _pair(_rod([-depth / 2, runner_y, bar], [depth / 2, runner_y, bar], bar))
        for x in (-depth / 2 + bar, depth / 2 - bar):
            parts += _pair(_rod([x, runner_y, bar], [x * 0.9, runner_y, under], bar))

    back_h, back_t = rng.uniform(0.3, 0.55), rng.uniform(0.02, 0.06)
    tilt = _rotation("y", -math.radians(rng.uniform(0.0, 15.0)))
    style = _pick(rng, ["solid", "slats", "frame"], [0.5, 0.25, 0.25])
    back_parts: list[_Part] = []  # built upright at the origin, then tilted and moved
    if style == "solid":
        back_parts.append(_centred_box([0.0, 0.0, back_h / 2], [back_t, width, back_h]))
    else:  # two posts and a top rail, with vertical slats or a middle rail
        post = rng.uniform(0.025, 0.045)
        rail_h = back_h * rng.uniform(0.12, 0.3)
        back_parts += _pair(_centred_box([0.0, width / 2 - post / 2, back_h / 2],
                                         [back_t, post, back_h]))
        back_parts.append(_centred_box([0.0, 0.0, back_h - rail_h / 2], [back_t, width, rail_h]))
        if style == "slats":
            n_slats = int(rng.integers(2, 6))
            for y in np.linspace(-width / 2 + post, width / 2 - post, n_slats + 2)[1:-1]:
                back_parts.append(_centred_box([0.0, y, (back_h - rail_h) / 2],
                                               [back_t * 0.6, post * 0.6, back_h - rail_h]))
        else:
            middle_rail = _centred_box([0.0, 0.0, back_h * 0.35], [back_t, width, rail_h * 0.6])
            back_parts.append(middle_rail)
    anchor = [-depth / 2 + back_t / 2, 0.0, seat_z]
    parts += [_moved(part, rotation=tilt, offset=anchor) for part in back_parts]

    if rng.random() < 0.35:  # armrests: a post at the front and a rest along the side
        arm_h, arm_w = rng.uniform(0.17, 0.25), rng.uniform(0.04, 0.07)
        arm_y = width / 2 + arm_w / 2 * rng.uniform(-1.0, 1.0)
        parts += _pair(_centred_box([depth * 0.35, arm_y, seat_z + arm_h / 2],
                                    [arm_w * 0.6, arm_w * 0.6, arm_h]))
        parts += _pair(_centred_box([0.0, arm_y, seat_z + arm_h], [depth * 0.95, arm_w, 0.03]))
    return parts


def _sofa(rng: np.random.Generator) -> list[_Part]:
    """Base, 1-4 seat cushions, thick back, usually arms (flat or rolled), legs, rarely a chaise."""
    length, depth = rng.uniform(1.3, 2.5), rng.uniform(0.8, 1.0)
    seat_z, cushion_t = rng.uniform(0.38, 0.48), rng.uniform(0.1, 0.18)
    leg_h = rng.uniform(0.05, 0.15) if rng.random() < 0.7 else 0.0
    back_t, back_z = rng.uniform(0.15, 0.25), rng.uniform(0.75, 1.0)
    has_arms = rng.random() < 0.9
    arm_w = rng.uniform(0.1, 0.25) if has_arms else 0.0
    x0, x1, y = -depth / 2, depth / 2, length / 2
    parts = [
        _box([x0, -y, leg_h], [x1, y, seat_z - cushion_t]),  # base
        _box([x0, -y + arm_w, leg_h], [x0 + back_t, y - arm_w, back_z]),  # back
    ]
    inner = length - 2 * arm_w
    n_seats = int(np.clip(round(inner / 0.6), 1, 4))
    seat_w = inner / n_seats
    has_back_cushions = rng.random() < 0.5
    lean = _rotation("y", -math.radians(rng.uniform(5.0, 15.0)))
    back_cushion = _box([0.0, 0.005, 0.0], [cushion_t, seat_w - 0.005, (back_z - seat_z) * 0.85])
    for k in range(n_seats):
        y0 = -inner / 2 + k * seat_w
        parts.append(_box([x0 + back_t, y0 + 0.005, seat_z - cushion_t - 0.01],
                          [x1, y0 + seat_w - 0.005, seat_z]))
        if has_back_cushions:  # leaning against the back
            parts.append(_moved(back_cushion, rotation=lean, offset=[x0 + back_t, y0, seat_z]))
    if has_arms:
        arm_z = rng.uniform(0.55, 0.7)
        parts += _pair(_box([x0, y - arm_w, leg_h], [x1, y, arm_z]))
        if rng.random() < 0.4:  # rolled arms
            roll = _cylinder(arm_w / 2 * 1.1, x0, x1, n_segments=16)
            parts += _pair(_moved(roll, rotation=_Z_TO_X, offset=[0.0, y - arm_w / 2, arm_z]))
    if leg_h > 0:
        leg = _frustum(rng.uniform(0.014, 0.025), rng.uniform(0.02, 0.035), 0.0, leg_h + 0.01,
                       n_segments=12)
        for x in (x0 + 0.06, x1 - 0.06):
            parts += _pair(_moved(leg, offset=[x, y - 0.06, 0.0]))
    if rng.random() < 0.15:  # a chaise longue on one side: breaks the mirror symmetry
        chaise_w = min(rng.uniform(0.6, 0.8), inner / 2)
        chaise = _box([x1 - 0.05, y - arm_w - chaise_w, 0.0],
                      [x1 + rng.uniform(0.5, 0.8), y - arm_w, seat_z])
        parts.append(chaise if rng.random() < 0.5 else _mirrored(chaise))
    return parts


def _table(rng: np.random.Generator) -> list[_Part]:
    """Rectangular or round top on four legs (maybe apron, shelf), 3 legs, pedestal or trestles."""
    height = rng.uniform(0.68, 0.78) if rng.random() < 0.75 else rng.uniform(0.38, 0.5)
    under = height - rng.uniform(0.025, 0.06)
    style = _pick(rng, ["four_legs", "three_legs", "pedestal", "trestle"], [0.5, 0.15, 0.2, 0.15])
    round_chance = {"four_legs": 0.2, "three_legs": 1.0, "pedestal": 0.7, "trestle": 0.0}[style]
    is_round = rng.random() < round_chance
    radius = rng.uniform(0.4, 0.7)
    length = rng.uniform(0.9, 2.0)
    width = rng.uniform(0.55, min(1.1, length))
    if style == "pedestal" and not is_round:  # a square top
        length = width = rng.uniform(0.6, 1.0)
    if is_round:
        parts = [_cylinder(radius, under, height, n_segments=32)]
        half_x = half_y = radius / math.sqrt(2.0)
    else:
        parts = [_box([-length / 2, -width / 2, under], [length / 2, width / 2, height])]
        half_x, half_y = length / 2, width / 2

    if style == "four_legs":
        leg, inset = rng.uniform(0.035, 0.08), rng.uniform(0.0, 0.1)
        leg_x, leg_y = half_x - inset - leg / 2, half_y - inset - leg / 2
        shape = _pick(rng, ["square", "round", "tapered"], [0.5, 0.25, 0.25])
        if shape == "square":
            leg_part = _centred_box([0.0, 0.0, under / 2], [leg, leg, under])
        else:
            foot_r = leg / 2 * (0.5 if shape == "tapered" else 1.0)
            leg_part = _frustum(foot_r, leg / 2, 0.0, under, n_segments=12)
        for x in (-leg_x, leg_x):
            parts += _pair(_moved(leg_part, offset=[x, leg_y, 0.0]))
        if rng.random() < 0.5:  # an apron under the top
            apron_h = rng.uniform(0.06, 0.12)
            z = under - apron_h / 2
            parts += _pair(_centred_box([0.0, leg_y, z], [2 * leg_x, 0.02, apron_h]))
            for x in (-leg_x, leg_x):
                parts.append(_centred_box([x, 0.0, z], [0.02, 2 * leg_y, apron_h]))
        if rng.random() < 0.2:  # a lower shelf
            z = rng.uniform(0.1, 0.25) * height
            parts.append(_centred_box([0.0, 0.0, z], [2 * leg_x + leg, 2 * leg_y + leg, 0.02]))
    elif style == "three_legs":  # at 0 and +-120 degrees, maybe splayed
        leg_r, splay = rng.uniform(0.015, 0.035), rng.uniform(0.0, 0.2) * radius
        leg_part = _rod([radius * 0.65, 0.0, under], [radius * 0.65 + splay, 0.0, 0.0], leg_r)
        for angle in (0.0, 2 * np.pi / 3, -2 * np.pi / 3):
            parts.append(_moved(leg_part, rotation=_rotation("z", angle)))
    elif style == "pedestal":  # a column, maybe bulging, on a domed disk or four feet
        column_r, bulge = rng.uniform(0.04, 0.09), rng.uniform(1.0, 1.8)
        parts.append(_revolve([[column_r, 0.02], [column_r * bulge, under * 0.3],
                               [column_r, under * 0.55], [column_r, under + 0.001]]))
        foot_span = max(half_x, half_y) * rng.uniform(0.6, 0.9)
        if rng.random() < 0.5:
            disk = [[foot_span, 0.0], [foot_span, 0.02], [foot_span * 0.3, 0.06]]
            parts.append(_revolve(disk, n_segments=32))
        else:  # on the axes or on the diagonals
            foot = _box([0.0, -0.025, 0.0], [foot_span, 0.025, 0.05])
            start = float(rng.choice([0.0, np.pi / 4]))
            for k in range(4):
                parts.append(_moved(foot, rotation=_rotation("z", start + k * np.pi / 2)))
    else:  # trestle: two end panels on feet, joined by a stretcher
        panel_t, inset = rng.uniform(0.04, 0.08), rng.uniform(0.05, 0.2)
        panel_x, panel_w = half_x - inset - panel_t / 2, width * rng.uniform(0.2, 0.6)
        for x in (-panel_x, panel_x):
            parts.append(_centred_box([x, 0.0, under / 2], [panel_t, panel_w, under]))
            parts.append(_centred_box([x, 0.0, 0.03], [panel_t * 1.5, width * 0.9, 0.06]))
        stretcher_z = under * rng.uniform(0.2, 0.6)
        parts.append(_centred_box([0.0, 0.0, stretcher_z], [2 * panel_x, 0.05, 0.08]))
    return parts


def _toilet(rng: np.random.Generator) -> list[_Part]:
    """Elongated hollow bowl, seat ring, maybe a lid (open or closed), tank, button or lever."""
    rim_z, rim_r = rng.uniform(0.36, 0.42), rng.uniform(0.17, 0.21)
    foot_r, base_r = rim_r * rng.uniform(0.45, 0.6), rim_r * rng.uniform(0.6, 0.85)
    elongation = rng.uniform(1.15, 1.45)  # the bowl is longer along x than wide
    depth = rim_z * rng.uniform(0.35, 0.55)
    rim_w = rim_r * rng.uniform(0.12, 0.2)
    inner_r = rim_r - rim_w
    bowl = _revolve([  # up the outside, over the rim and down into the cavity
        [base_r, 0.0], [foot_r, rim_z * 0.25], [foot_r * 1.1, rim_z * 0.5],
        [rim_r * 0.95, rim_z * 0.85], [rim_r, rim_z], [inner_r, rim_z],
        [inner_r * 0.6, rim_z - depth * 0.6], [inner_r * 0.3, rim_z - depth],
    ], n_segments=24)
    bowl_x = rim_r * elongation * 0.35
    parts = [_moved(bowl, scale=[elongation, 1.0, 1.0], offset=[bowl_x, 0.0, 0.0])]
    seat_t = rng.uniform(0.015, 0.03)
    ring = _torus(rim_r - rim_w / 2, rim_w * 0.6, n_minor=8)
    parts.append(_moved(ring, scale=[elongation, 1.0, seat_t / (rim_w * 1.2)],
                        offset=[bowl_x, 0.0, rim_z + seat_t / 2]))

    has_tank = rng.random() < 0.85
    tank_depth, tank_w = rng.uniform(0.15, 0.22), rng.uniform(0.35, 0.5)
    hinge_x = bowl_x - rim_r * elongation  # back of the rim
    tank_x = hinge_x - rng.uniform(0.0, 0.03)  # front face of the tank
    tank_top = rng.uniform(0.7, 0.8)
    lid = _moved(_cylinder(1.0, 0.0, 1.0, n_segments=24),
                 scale=[rim_r * elongation, rim_r, seat_t])
    lid_state = rng.random()
    if lid_state < 0.4:  # closed on the seat
        parts.append(_moved(lid, offset=[bowl_x, 0.0, rim_z + seat_t]))
    elif lid_state < 0.8:  # open, hinged at the back of the rim, leaning on the tank or wall
        lean_deg = rng.uniform(91.0, 93.0) if has_tank else rng.uniform(95.0, 110.0)
        hinged = _moved(lid, offset=[rim_r * elongation, 0.0, 0.0])
        parts.append(_moved(hinged, rotation=_rotation("y", -math.radians(lean_deg)),
                            offset=[hinge_x, 0.0, rim_z + seat_t]))
    if has_tank:
        tank_back, half_w = tank_x - tank_depth, tank_w / 2
        parts.append(_box([tank_back, -half_w, rim_z * 0.95], [tank_x, half_w, tank_top]))
        parts.append(_box([tank_back - 0.01, -half_w - 0.01, tank_top],
                          [tank_x + 0.01, half_w + 0.01, tank_top + 0.025]))  # tank lid
        parts.append(_box([tank_x - tank_depth * 0.6, -0.1, 0.05],
                          [tank_x + 0.01, 0.1, rim_z * 0.95]))  # back of the pedestal
        if rng.random() < 0.5:  # a push button on the tank lid (symmetric)
            parts.append(_cylinder(0.02, tank_top + 0.025, tank_top + 0.035, n_segments=12))
        else:  # a lever on the front face, on one side (asymmetric)
            side = 1.0 if rng.random() < 0.5 else -1.0
            parts.append(_centred_box([tank_x + 0.02, side * (half_w - 0.06), tank_top - 0.05],
                                      [0.04, 0.08, 0.015]))
    return parts


_BUILDERS: dict[str, Callable[[np.random.Generator], list[_Part]]] = {
    "airplane": _airplane,
    "bench": _bench,
    "bottle": _bottle,
    "car": _car,
    "chair": _chair,
    "sofa": _sofa,
    "table": _table,
    "toilet": _toilet,
}
