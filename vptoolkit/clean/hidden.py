"""Step 2 of :mod:`vptoolkit.clean`: remove hidden faces and orient the rest.

Owns :func:`remove_hidden_faces` and its result :class:`VisibleMesh`,
:func:`hidden_faces`, :func:`two_sided_pixel_totals` (each face drawn from both
sides over the Fibonacci views), :data:`HIDDEN_SETTINGS`, the rescue of
sub-pixel faces next to seen ones, the per-patch orientation vote, and the
test added after a step 1 that removed intersecting faces
(:func:`_hidden_before_resolving`). Needs no pymeshlab.

The views, image side, camera and backend of the hidden-face test are one
:class:`~vptoolkit.settings.MeasureSettings`, as for the measures; the
default, :data:`HIDDEN_SETTINGS`, is the measures' own but at
:data:`HIDDEN_RESOLUTION` pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import check_bool
from vptoolkit.clean.repair import RepairedMesh
from vptoolkit.clean.topology import coherent_patches, submesh
from vptoolkit.errors import InputError
from vptoolkit.geometry import bounding_frame, face_areas, face_normals, undirected_edges
from vptoolkit.mesh import Mesh, MeshLike, as_mesh
from vptoolkit.settings import MeasureSettings, check_settings
from vptoolkit.visibility import face_pixel_totals

HIDDEN_RESOLUTION: Final = 256
"""Default image side, in pixels, of the visibility pass that finds hidden faces."""

MIN_HIDDEN_RESOLUTION: Final = 8
"""Smallest image side the hidden-face test accepts: below it whole parts fall between pixels."""

HIDDEN_SETTINGS: Final = MeasureSettings(resolution=HIDDEN_RESOLUTION)
"""Default settings of the hidden-face test: 1000 Fibonacci views, ``Camera()``,
the raster backend, at :data:`HIDDEN_RESOLUTION` pixels."""

_BACK_OFFSET = 1e-5
"""Offset of the reversed copy of each face in :func:`hidden_faces`, in diagonals."""


@dataclass(frozen=True, eq=False, repr=False, kw_only=True)
class VisibleMesh(Mesh):
    """The mesh :func:`remove_hidden_faces` returns: a :class:`~vptoolkit.mesh.Mesh` and what went.

    Attributes
    ----------
    hidden_area : float
        Area of the faces removed, in model units squared.
    hidden_area_fraction : float
        ``hidden_area`` over the area of the input (0 for an input of no area).
    faces_flipped : int
        Kept faces reversed because they were seen mostly from behind.
    """

    hidden_area: float
    hidden_area_fraction: float
    faces_flipped: int


def check_hidden_settings(value: object, name: str = "settings") -> MeasureSettings:
    """Return ``value`` if it is a :class:`~vptoolkit.settings.MeasureSettings` the test accepts.

    Raises
    ------
    InputError
        If ``value`` is not a ``MeasureSettings``
        (:func:`~vptoolkit.settings.check_settings`) or its ``resolution``
        is below :data:`MIN_HIDDEN_RESOLUTION`, e.g.
        ``settings: resolution must be at least 8 for the hidden-face test, got 4``.
    """
    settings = check_settings(value, name)
    if settings.resolution < MIN_HIDDEN_RESOLUTION:
        raise InputError(f"{name}: resolution must be at least {MIN_HIDDEN_RESOLUTION} for the "
                         f"hidden-face test, got {settings.resolution}")
    return settings


def two_sided_pixel_totals(
    mesh: MeshLike,
    settings: MeasureSettings = HIDDEN_SETTINGS,
) -> NDArray[np.int64]:
    """Pixels of each face over all views, seen from its front and from its back.

    Counts with :func:`~vptoolkit.visibility.face_pixel_totals` over the
    ``settings.views`` directions of :func:`~vptoolkit.sphere.fibonacci_sphere`
    (back faces culled, the model framed as for the measures). Each face is
    drawn from both sides: a reversed copy sits ``1e-5`` bounding-box
    diagonals behind it. The copy is offset rather than coincident, so depth
    ties cannot hide either side.

    Parameters
    ----------
    mesh : MeshLike
        The mesh to test.
    settings : MeasureSettings
        Views, image side, camera and backend (default:
        :data:`HIDDEN_SETTINGS`, 1000 views as in the paper at 256 pixels).
        A face smaller than a pixel is still hit in some of the many
        slightly shifted views; a lower ``resolution`` (at least 8) is faster
        but may miss small faces in deep concavities.

    Returns
    -------
    pixels : (n_faces, 2) int64
        Column 0: pixels where the face is seen from the side its normal
        points to (the front); column 1: pixels where it is seen from behind.
        Zero-area faces are never drawn and have ``(0, 0)``.

    Raises
    ------
    InputError
        On a bad argument (:func:`check_hidden_settings`).
    """
    mesh = as_mesh(mesh)
    settings = check_hidden_settings(settings)
    n_faces = mesh.n_faces
    _, diagonal = bounding_frame(mesh)
    offset = _BACK_OFFSET * diagonal
    corners = mesh.vertices[mesh.faces] - offset * face_normals(mesh)[:, None, :]
    back_faces = mesh.n_vertices + np.arange(3 * n_faces, dtype=np.int64).reshape(-1, 3)[:, ::-1]
    two_sided = Mesh(
        np.vstack([mesh.vertices, corners.reshape(-1, 3)]),
        np.vstack([mesh.faces, back_faces]),
        name=mesh.name,
    )
    totals = face_pixel_totals(two_sided, settings)
    return np.stack([totals[:n_faces], totals[n_faces:]], axis=1).astype(np.int64)


def hidden_faces(
    mesh: MeshLike,
    settings: MeasureSettings = HIDDEN_SETTINGS,
) -> NDArray[np.bool_]:
    """Find the faces seen in none of the views, from either side.

    Raw models often have inverted or inconsistently oriented faces, which
    back-face culling would hide in every view, so a face counts as seen if
    its front or its back covers a pixel (:func:`two_sided_pixel_totals`).

    Parameters
    ----------
    mesh : MeshLike
        The mesh to test.
    settings : MeasureSettings
        Views, image side, camera and backend (default:
        :data:`HIDDEN_SETTINGS`, 1000 views at 256 pixels).

    Returns
    -------
    is_hidden : (n_faces,) bool
        True for each face that covers no pixel in any view.

    Notes
    -----
    A face much smaller than a pixel can be missed by every pixel centre
    although it is on the surface, e.g. the slivers that a boolean union
    leaves along an intersection curve. So an unseen face smaller than one
    pixel (at the camera's distance from the model centre) that shares an
    edge with a seen face counts as seen, up to two such rings deep. Large
    unseen faces are always hidden.

    Raises
    ------
    InputError
        On a bad argument (:func:`check_hidden_settings`).
    """
    mesh = as_mesh(mesh)
    settings = check_hidden_settings(settings)
    pixels = two_sided_pixel_totals(mesh, settings)
    return keep_small_faces_by_seen_ones(mesh, pixels.sum(axis=1) == 0, settings)


def remove_hidden_faces(
    mesh: MeshLike,
    settings: MeasureSettings = HIDDEN_SETTINGS,
    *,
    orient: bool = True,
) -> VisibleMesh:
    """Step 2: drop the faces seen in none of the views and orient the rest.

    A face is dropped if neither side covers a pixel in any view
    (:func:`hidden_faces`). Removing intersecting faces in step 1 can open
    seams through which buried parts become visible, so when ``mesh`` is the
    :class:`~vptoolkit.clean.repair.RepairedMesh` of a step 1 that did, a face
    is also dropped if the face it comes from was already hidden before the
    intersections were resolved. With ``orient``, the kept faces are turned
    towards the side they are seen from, because raw models often mix inward
    and outward faces and the measures cull back faces. The vote is per patch
    of consistently wound faces joined by manifold edges: a patch whose faces
    cover more pixels from behind than from the front is reversed as a whole.
    A consistently outward-oriented mesh is left as it is; a triangle soup
    is oriented face by face.

    Parameters
    ----------
    mesh : MeshLike
        The repaired mesh, as :func:`~vptoolkit.clean.repair.repair_mesh`
        returns it.
    settings : MeasureSettings
        Views, image side, camera and backend (default:
        :data:`HIDDEN_SETTINGS`, 1000 views at 256 pixels).
    orient : bool
        Reverse the faces seen mostly from behind (default: True).

    Returns
    -------
    visible : VisibleMesh
        The faces seen from some view, without unreferenced vertices, and the
        hidden area and flipped faces.

    Raises
    ------
    InputError
        On a bad argument (:func:`check_hidden_settings`).
    MeasurementError
        If no face is seen; the message starts with the mesh name.
    """
    mesh = as_mesh(mesh)
    orient = check_bool(orient, "orient")
    settings = check_hidden_settings(settings)
    pixels = two_sided_pixel_totals(mesh, settings)
    is_hidden = pixels.sum(axis=1) == 0
    if isinstance(mesh, RepairedMesh) and mesh.method != "none":
        is_hidden |= _hidden_before_resolving(mesh, settings)
    is_hidden = keep_small_faces_by_seen_ones(mesh, is_hidden, settings)
    if orient:
        is_flipped = seen_from_behind(mesh.faces, np.where(is_hidden[:, None], 0, pixels))
        is_flipped &= ~is_hidden
    else:
        is_flipped = np.zeros(mesh.n_faces, dtype=bool)
    areas = face_areas(mesh)
    hidden_area = float(areas[is_hidden].sum())
    total_area = float(areas.sum())
    visible = submesh(mesh, ~is_hidden, "remove_hidden", flip=is_flipped)
    return VisibleMesh(
        visible.vertices,
        visible.faces,
        visible.name,
        hidden_area=hidden_area,
        hidden_area_fraction=hidden_area / total_area if total_area > 0.0 else 0.0,
        faces_flipped=int(is_flipped.sum()),
    )


def _hidden_before_resolving(repaired: RepairedMesh,
                             settings: MeasureSettings) -> NDArray[np.bool_]:
    """Repaired faces that were hidden before the self-intersections were resolved.

    Resolving intersections by removal opens seams through which buried parts
    can be seen. This renders the mesh as it was before (``connected``, whose
    intersecting faces still close the seams) together with the faces step 1
    created (hole fillings), and maps the result onto the repaired faces:
    a kept face inherits the flag of the face it comes from, a new face gets
    its own. New faces come last, so where one exactly covers a removed face
    the rasteriser's depth tie goes to the new face.
    """
    connected, origin = repaired.connected, repaired.origin
    is_new = origin < 0
    scene = Mesh(
        np.vstack([connected.vertices, repaired.vertices]),
        np.vstack([connected.faces, repaired.faces[is_new] + connected.n_vertices]),
        name=connected.name,
    )
    pixels = two_sided_pixel_totals(scene, settings)
    was_hidden = pixels.sum(axis=1) == 0
    is_hidden = np.zeros(repaired.n_faces, dtype=bool)
    is_hidden[~is_new] = was_hidden[origin[~is_new]]
    is_hidden[is_new] = was_hidden[connected.n_faces :]
    return is_hidden


def keep_small_faces_by_seen_ones(
    mesh: Mesh, is_hidden: NDArray[np.bool_], settings: MeasureSettings, *, rings: int = 2
) -> NDArray[np.bool_]:
    """Count sub-pixel unseen faces next to seen ones as seen (see :func:`hidden_faces`).

    A pixel's side at the camera's distance from the model centre is
    ``2 d tan(fov / 2) / resolution`` with ``d`` the camera's
    ``distance_factor`` times the bounding-box diagonal (``settings.camera``
    and ``settings.resolution``); an unseen face of less area than a pixel
    that shares an edge with a seen face counts as seen, ``rings`` times over.
    """
    if not is_hidden.any() or is_hidden.all():
        return is_hidden
    camera = settings.camera
    _, diagonal = bounding_frame(mesh)
    distance = camera.distance_factor * diagonal
    pixel = 2.0 * distance * math.tan(math.radians(camera.fov_deg) / 2.0) / settings.resolution
    is_small = face_areas(mesh) < pixel * pixel
    candidates = is_hidden & is_small
    if not candidates.any():
        return is_hidden
    edge_id, counts = undirected_edges(mesh.faces)
    is_hidden = is_hidden.copy()
    for _ in range(rings):
        edge_seen = np.zeros(len(counts), dtype=bool)
        edge_seen[edge_id[~is_hidden].ravel()] = True
        rescued = candidates & is_hidden & edge_seen[edge_id].any(axis=1)
        if not rescued.any():
            break
        is_hidden[rescued] = False
    return is_hidden


def seen_from_behind(faces: NDArray[np.int64], pixels: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Faces of the coherent patches that cover more pixels from behind than from the front."""
    patch = coherent_patches(faces)
    front = np.bincount(patch, weights=pixels[:, 0])
    back = np.bincount(patch, weights=pixels[:, 1])
    return np.asarray((back > front)[patch], dtype=bool)
