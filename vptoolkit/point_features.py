"""Per-point features a network reads beside the coordinates: from faces, or from the points.

Points sampled uniformly by area (:func:`vptoolkit.points.sample_surface`)
describe the shape, not how it is cut into faces. Viewpoint entropy and
viewpoint mutual information weigh each face's projected area, so of two
views showing the same area the one showing more, smaller faces scores
higher; a network that reads points alone cannot tell the two apart. A
point feature gives each point a number from its mesh:

``"face_area"``
    ``clip(ln(A_f / A_mean) / 2, -3, 3)`` for the face ``f`` the point lies
    on, with ``A_mean`` the mean face area of the mesh (total area over the
    number of faces): 0 on a mesh of equal faces, +1 on a face ``e^2`` (about
    7.4) times the mean, -1 on one 7.4 times smaller. Unitless and unchanged
    by rotating, moving or scaling the mesh. One column.

``"normal"``
    The unit normal of that face by the right-hand rule on its winding
    (:func:`vptoolkit.geometry.face_normals`), in the mesh's coordinates; the
    zero vector on a degenerate face. Three columns, a vector: it turns with
    the points (:func:`turn_features`), and a mesh wound inconsistently
    gives normals of both signs, as it is. A point cloud that has normals
    carries this one as its own normals.

Those two (:data:`FACE_FEATURES`) need the faces. Two more
(:data:`CLOUD_FEATURES`) are computed from the points alone, the whole
surface sample or cloud a network's inputs are drawn from, so a mesh, a
dataset's stored points and a bare point cloud all carry them, the same way:

``"spacing_area"``
    ``clip(ln(A_i / mean_j A_j) / 2, -3, 3)`` with ``A_i = pi d_8^2 / 8`` the
    area of surface point ``i`` stands for, from the distance to its 8th
    nearest point (:func:`vptoolkit.point_areas.point_areas`): the
    face-area feature's normalisation applied to the sampling's own spacing.
    On an area-uniform sample it is noise about 0 (a relative spread of
    ``1 / sqrt(8)``); on a scan it follows the scanner's distance and angle.
    One column.

``"estimated_normal"``
    The unit normal of the plane through the point and its 8 nearest
    points, turned away from the centroid of all the points
    (:func:`vptoolkit.cloud_sample.estimate_normals`). Three columns, a
    vector that turns with the points.

A point given more than once (a stored sample drawn with repeats from a cloud
of fewer points) counts once in both neighbourhoods.

:func:`point_features` stacks named features, ``(n, F)`` with ``F =``
:func:`feature_width`, in the order given; :data:`POINT_FEATURES` lists the
names. Whoever turns points turns their vector features alike
(:func:`turn_features`). The face each point lies on is
known when the points are sampled (``sample_surface(...).face_index``); for
stored points it is found again by :func:`locate_faces` (the nearest face,
with numba, from the ``measures`` extra). Numpy only otherwise.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import short_repr
from vptoolkit.errors import InputError
from vptoolkit.geometry import face_areas, face_normals
from vptoolkit.mesh import MeshLike, as_mesh

__all__ = ["POINT_FEATURES", "FACE_FEATURES", "CLOUD_FEATURES", "FEATURE_WIDTHS",
           "FACE_AREA_CLIP", "check_feature_names", "face_area_feature", "feature_width",
           "locate_faces", "normal_feature", "spacing_area_feature", "point_features",
           "turn_features"]

FACE_FEATURES: Final = ("face_area", "normal")
"""Features read from the face under each point: a mesh's, or a dataset's stored mesh's."""

CLOUD_FEATURES: Final = ("spacing_area", "estimated_normal")
"""Features computed from the points alone, which every model carries, a bare cloud too."""

POINT_FEATURES: Final = FACE_FEATURES + CLOUD_FEATURES
"""Names :func:`point_features` computes."""

FEATURE_WIDTHS: Final = {"face_area": 1, "normal": 3, "spacing_area": 1, "estimated_normal": 3}
"""Columns of each feature: 1 for a number, 3 for a vector that turns with the points."""

FACE_AREA_CLIP: Final = 3.0
"""``"face_area"`` is clipped to ``[-FACE_AREA_CLIP, FACE_AREA_CLIP]``."""

_GRID_CELLS = 64  # most grid cells along an axis in locate_faces
_SLACK = 1e-4  # faces are searched for points within this share of the mesh's diagonal


def check_feature_names(names: Any, *, text: bool = False) -> tuple[str, ...]:
    """Return ``names`` as a tuple of distinct names of :data:`POINT_FEATURES`, or raise.

    Parameters
    ----------
    names : sequence of str
        Feature names, in order.
    text : bool
        Also take one string, as a command line gives it: comma-separated
        names, or ``"none"`` for no feature (default: False).

    Raises
    ------
    InputError
        ``point_features: ...`` for something other than a sequence of
        strings, an unknown name or a repeated one.
    """
    if text and isinstance(names, str):
        names = [] if names.strip() == "none" else [name.strip() for name in names.split(",")]
    if isinstance(names, str) or not isinstance(names, (list, tuple)) or not all(
            isinstance(name, str) for name in names):
        raise InputError(f"point_features: expected a list of names, got {short_repr(names, 80)}")
    unknown = [name for name in names if name not in POINT_FEATURES]
    if unknown:
        raise InputError(f"point_features: unknown {short_repr(unknown, 80)}, expected names of "
                         f"{list(POINT_FEATURES)}")
    if len(set(names)) != len(names):
        raise InputError(f"point_features: {short_repr(list(names), 80)} names a feature twice")
    return tuple(names)


def _check_face_index(face_index: ArrayLike, n_faces: int, name: str) -> NDArray[np.int64]:
    index = np.asarray(face_index)
    if index.ndim != 1 or not np.issubdtype(index.dtype, np.integer):
        raise InputError(f"{name}: face_index: expected a 1-d integer array, got "
                         f"{index.dtype} of shape {index.shape}")
    if len(index) and (index.min() < 0 or index.max() >= n_faces):
        raise InputError(f"{name}: face_index: expected indices in [0, {n_faces}), got "
                         f"{int(index.min())} to {int(index.max())}")
    return index.astype(np.int64, copy=False)


def face_area_feature(mesh: MeshLike, face_index: ArrayLike) -> NDArray[np.float32]:
    """The ``"face_area"`` feature of points lying on the faces ``face_index`` of ``mesh``.

    Parameters
    ----------
    mesh : MeshLike
        The mesh; its total area must be positive.
    face_index : (n,) int
        The face each point lies on.

    Returns
    -------
    feature : (n,) float32
        ``clip(ln(A_f / A_mean) / 2, -3, 3)`` (module docstring); a face of
        zero area gets -3.

    Examples
    --------
    >>> import numpy as np
    >>> square = (np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0], [1, 1, 0]], float),
    ...           np.array([[0, 1, 4], [1, 2, 4], [2, 3, 0]]))
    >>> face_area_feature(square, [0, 2]).astype(float).round(3).tolist()  # areas 1, 2; mean 4/3
    [-0.144, 0.203]
    """
    mesh = as_mesh(mesh)
    index = _check_face_index(face_index, len(mesh.faces), mesh.name)
    areas = face_areas(mesh)
    mean = float(areas.sum()) / len(areas)
    if not mean > 0.0:
        raise InputError(f"{mesh.name}: mesh has zero surface area, no face areas to compare")
    with np.errstate(divide="ignore"):
        logs = np.log(areas[index] / mean) / 2.0
    return np.clip(logs, -FACE_AREA_CLIP, FACE_AREA_CLIP).astype(np.float32)


def normal_feature(mesh: MeshLike, face_index: ArrayLike) -> NDArray[np.float32]:
    """The ``"normal"`` feature of points lying on the faces ``face_index`` of ``mesh``.

    Returns
    -------
    feature : (n, 3) float32
        The unit normal of each point's face by its winding, in the mesh's
        coordinates; zero for a degenerate face.

    Examples
    --------
    >>> import numpy as np
    >>> square = (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float),
    ...           np.array([[0, 1, 2], [0, 3, 2]]))
    >>> normal_feature(square, [0, 1]).tolist()  # counter-clockwise seen from +z, then clockwise
    [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]
    """
    mesh = as_mesh(mesh)
    index = _check_face_index(face_index, len(mesh.faces), mesh.name)
    return face_normals(mesh)[index].astype(np.float32)


def feature_width(names: Sequence[str]) -> int:
    """Columns of the named features together: the ``F`` of :func:`point_features`."""
    return sum(FEATURE_WIDTHS[name] for name in check_feature_names(names))


def turn_features(features: Any, names: Sequence[str], turn: Any) -> Any:
    """Features of turned points: each vector feature's columns ``v`` become ``v @ turn``.

    Points turned as ``x @ turn`` (``turn = R.T`` for a rotation ``R``, the
    canonical frame's ``C.T``) keep their features this way: numbers stay,
    vectors turn alike. Numpy arrays or torch tensors, ``(..., n, F)``, with
    ``turn`` ``(3, 3)`` or one per leading index, ``(..., 3, 3)``; the
    input is not changed, and with no vector feature it comes back as is.

    Examples
    --------
    >>> import numpy as np
    >>> quarter = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # x -> y
    >>> turn_features(np.array([[0.5, 1.0, 0.0, 0.0]]), ["face_area", "normal"], quarter).tolist()
    [[0.5, 0.0, 1.0, 0.0]]
    """
    names = check_feature_names(names)
    starts, offset = [], 0
    for name in names:
        if FEATURE_WIDTHS[name] == 3:
            starts.append(offset)
        offset += FEATURE_WIDTHS[name]
    if not starts:
        return features
    turned = features.clone() if hasattr(features, "clone") else np.array(features)
    for start in starts:
        turned[..., start:start + 3] = features[..., start:start + 3] @ turn
    return turned


def spacing_area_feature(points: ArrayLike) -> NDArray[np.float32]:
    """The ``"spacing_area"`` feature of a cloud's points.

    Parameters
    ----------
    points : (n, 3) array_like
        The whole cloud or surface sample, more than 8 distinct points.

    Returns
    -------
    feature : (n,) float32
        ``clip(ln(A_i / mean_j A_j) / 2, -3, 3)`` of the spacing areas
        (:func:`vptoolkit.point_areas.point_areas`, ``k = 8``) of the distinct
        points, the mean over them; a point given more than once (a sample
        drawn with repeats) is one point of surface and gets its value each
        time. Unitless and unchanged by rotating, moving or scaling the points.

    Raises
    ------
    InputError
        For 8 distinct points or fewer.

    Examples
    --------
    >>> import numpy as np
    >>> grid = np.stack(np.meshgrid(np.arange(10.0), np.arange(10.0), [0.0]), -1).reshape(-1, 3)
    >>> spaced = np.concatenate([grid, 3.0 * grid + [40.0, 0.0, 0.0]])  # 3x the spacing
    >>> feature = spacing_area_feature(spaced)
    >>> round(float(feature[150] - feature[50]), 3)  # ln(9) / 2: nine times the area
    1.099
    >>> bool((spacing_area_feature(np.concatenate([spaced, spaced[:7]]))[:200] == feature).all())
    True
    """
    distinct, inverse = _distinct(points)
    return _spacing_area(distinct)[inverse]


def _spacing_area(distinct: NDArray[np.float64]) -> NDArray[np.float32]:
    """:func:`spacing_area_feature` of points that are all distinct."""
    from vptoolkit.point_areas import point_areas

    areas = point_areas(distinct)
    with np.errstate(divide="ignore"):
        logs = np.log(areas / float(areas.mean())) / 2.0
    return np.clip(logs, -FACE_AREA_CLIP, FACE_AREA_CLIP).astype(np.float32)


def _distinct(points: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """The distinct rows of ``points`` and each point's row among them; more than 8 or an
    InputError (the neighbourhoods of the cloud features need 8 other points)."""
    cloud = np.asarray(points, dtype=np.float64)
    if cloud.ndim != 2 or cloud.shape[1] != 3:
        raise InputError(f"points: expected an (n, 3) array, got shape {cloud.shape}")
    distinct, inverse = np.unique(cloud, axis=0, return_inverse=True)
    if len(distinct) <= 8:
        raise InputError(f"points: {len(distinct)} distinct points, need more than 8 for the "
                         "features of their neighbourhoods")
    return distinct, inverse.reshape(-1)


def point_features(points: ArrayLike, names: Sequence[str], *, mesh: MeshLike | None = None,
                   face_index: ArrayLike | None = None) -> NDArray[np.float32]:
    """The named features of ``points``: the whole surface sample or cloud.

    Parameters
    ----------
    points : (n, 3) array_like
        The points, in the mesh's coordinates where there is one.
    names : sequence of str
        Names of :data:`POINT_FEATURES`, in order.
    mesh : MeshLike, optional
        The mesh the points lie on, for :data:`FACE_FEATURES`.
    face_index : (n,) int, optional
        The face of ``mesh`` each point lies on, for :data:`FACE_FEATURES`.

    Returns
    -------
    features : (n, F) float32
        The columns of each name (:data:`FEATURE_WIDTHS`), in the order given
        (``(n, 0)`` for no names).

    Raises
    ------
    InputError
        For a bad name, or a face feature asked of points without their
        mesh and faces (a point cloud).
    """
    from vptoolkit.cloud_sample import estimate_normals

    names = check_feature_names(names)
    cloud = np.asarray(points, dtype=np.float64)
    faceless = [name for name in names if name in FACE_FEATURES]
    if faceless and (mesh is None or face_index is None):
        raise InputError(f"point_features: {', '.join(faceless)} reads the faces under the "
                         "points, and these have none (a point cloud carries "
                         f"{', '.join(CLOUD_FEATURES)})")

    if any(name in CLOUD_FEATURES for name in names):  # once for both cloud features
        distinct, inverse = _distinct(cloud)

    def column(name: str) -> NDArray[np.float32]:
        if name == "spacing_area":
            return _spacing_area(distinct)[inverse, None]
        if name == "estimated_normal":  # a repeated point has its distinct point's normal
            return estimate_normals(distinct).astype(np.float32)[inverse]
        assert mesh is not None and face_index is not None  # checked above
        if name == "face_area":
            return face_area_feature(mesh, face_index)[:, None]
        return normal_feature(mesh, face_index)

    return np.concatenate([column(name) for name in names], axis=1) if names else (
        np.zeros((len(cloud), 0), np.float32))


def locate_faces(mesh: MeshLike, points: ArrayLike) -> NDArray[np.int64]:
    """The face of ``mesh`` nearest to each point: the face a surface point lies on.

    Exact Euclidean point-to-triangle distances. A point within 1e-4 of the
    diagonal (of the mesh and points together) of the surface is compared
    with the faces whose bounding box, widened by that much, holds it (found
    through a uniform grid over the points); a point farther off, with every
    face. So any point gets its nearest face, and surface points get it
    quickly (about 0.03 s for 20000 points on 10000 faces). Ties go to the
    lower face index, so a point on an edge gets the first of its faces. For
    points sampled on
    a mesh and stored in float32 this gives back the sampled face, or a face
    sharing the point (on an edge) when rounding moved it there.

    Parameters
    ----------
    mesh : MeshLike
        The mesh, with at least one face.
    points : (n, 3) float
        Points, in the mesh's coordinates.

    Returns
    -------
    face_index : (n,) int64

    Raises
    ------
    InputError
        If ``points`` is not an ``(n, 3)`` array of finite numbers.
    """
    from vptoolkit._face_location import nearest_faces

    mesh = as_mesh(mesh)
    query = np.asarray(points, dtype=np.float64)
    if query.ndim != 2 or query.shape[1] != 3 or not np.isfinite(query).all():
        raise InputError(f"{mesh.name}: points: expected an (n, 3) array of finite numbers, "
                         f"got shape {query.shape}")
    if not len(query):
        return np.zeros(0, np.int64)
    low = np.minimum(query.min(axis=0), mesh.vertices.min(axis=0))
    high = np.maximum(query.max(axis=0), mesh.vertices.max(axis=0))
    slack = _SLACK * max(float(np.linalg.norm(high - low)), 1e-12)
    cells = max(1, min(_GRID_CELLS, round(len(query) ** (1 / 3))))
    size = max(float((high - low).max()) / cells, 1e-12)
    shape = np.minimum(np.floor((high - low) / size).astype(np.int64) + 1, _GRID_CELLS)
    cell = np.minimum(np.floor((query - low) / size).astype(np.int64), shape - 1)
    keys = (cell[:, 0] * shape[1] + cell[:, 1]) * shape[2] + cell[:, 2]
    order = np.argsort(keys, kind="stable")
    starts = np.searchsorted(keys[order], np.arange(int(np.prod(shape)) + 1))
    return nearest_faces(mesh.vertices, mesh.faces.astype(np.int64), query, low, size, shape,
                          order.astype(np.int64), starts.astype(np.int64), slack)
