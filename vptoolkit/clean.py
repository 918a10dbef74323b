"""Mesh cleaning: the paper's three-step pipeline, with numbers on what it changed.

Schelling et al. (2021, appendix "Mesh Cleaning Pipeline") clean every model
before measuring it, because self-intersections, hidden parts and uneven
tessellation distort the viewpoint quality measures (a face's area no longer
matches its potentially visible area, which changes ``A_t`` and ``A_z``).
:func:`clean_mesh` runs the same three steps; each is also available alone:

1. :func:`repair_mesh` -- remove null and duplicate faces, merge duplicate
   vertices, drop unreferenced vertices, repair non-manifold edges and
   vertices, and resolve self-intersections (see its Notes for how and why).
2. :func:`remove_hidden_faces` -- drop the faces seen in none of the 1000
   views (:func:`hidden_faces`), e.g. passenger seats inside an airplane,
   and turn each remaining face towards the side it is seen from.
3. :func:`simplify_mesh` -- quadric edge-collapse decimation to at most
   ``max_faces`` faces (the paper keeps models under 10k faces), optionally
   followed by isotropic remeshing.

:class:`CleaningReport` records faces and vertices before and after each
step, self-intersections before and after, the hidden area removed and the
seconds per step; :meth:`CleaningReport.to_dict` gives JSON types.

pymeshlab is imported lazily (``pip install 'vptoolkit[clean]'``). A mesh that
cannot be cleaned raises :class:`~vptoolkit.errors.MeasurementError` whose
message starts with the mesh name; no step ever returns an empty mesh.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import check_bool, check_int, one_line
from vptoolkit.camera import Camera
from vptoolkit.conventions import N_VIEWS
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.geometry import bounding_frame, face_areas, face_normals
from vptoolkit.mesh import Mesh
from vptoolkit.optional import require
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.visibility import face_pixel_totals

if TYPE_CHECKING:
    import pymeshlab

__all__ = [
    "MAX_FACES",
    "HIDDEN_RESOLUTION",
    "MERGE_TOLERANCE",
    "SelfIntersectionMethod",
    "StepReport",
    "CleaningReport",
    "clean_mesh",
    "repair_mesh",
    "two_sided_pixel_totals",
    "hidden_faces",
    "remove_hidden_faces",
    "simplify_mesh",
    "count_self_intersections",
]

MAX_FACES = 10_000
"""Default face budget after cleaning (the paper uses models with at most 10k faces)."""

HIDDEN_RESOLUTION = 256
"""Default image side, in pixels, of the visibility pass that finds hidden faces."""

MERGE_TOLERANCE = 1e-6
"""Vertices closer than this fraction of the bounding-box diagonal are merged."""

SelfIntersectionMethod = Literal["auto", "remove"]
"""How :func:`repair_mesh` resolves self-intersections (see its Notes)."""

_HOLE_EDGES = 30
"""Largest hole, in border edges, that the ``"remove"`` method closes."""

_SPLIT_DISPLACEMENT = 0.01
"""How far a split non-manifold vertex moves towards its faces, as a fraction of their size.

Coincident copies would leave faces touching at a point without sharing a
vertex, which pymeshlab's self-intersection test reports unreliably.
"""

_AFTER_DECIMATION_ROUNDS = 3
"""Rounds of removing the faces that decimation left intersecting (see :func:`clean_mesh`)."""

_BACK_OFFSET = 1e-5
"""Offset of the reversed copy of each face in :func:`hidden_faces`, in diagonals."""

_STEP_NAMES = ("repair", "remove_hidden", "simplify")


@dataclass(frozen=True)
class StepReport:
    """Sizes and time of one cleaning step.

    Attributes
    ----------
    name : str
        ``"repair"``, ``"remove_hidden"`` or ``"simplify"``.
    faces_before, faces_after : int
        Number of triangles entering and leaving the step.
    vertices_before, vertices_after : int
        Number of vertices entering and leaving the step.
    seconds : float
        Wall-clock time of the step.
    """

    name: str
    faces_before: int
    faces_after: int
    vertices_before: int
    vertices_after: int
    seconds: float

    def to_dict(self) -> dict[str, str | int | float]:
        """Return the fields as a JSON-safe dict."""
        return {
            "name": self.name,
            "faces_before": int(self.faces_before),
            "faces_after": int(self.faces_after),
            "vertices_before": int(self.vertices_before),
            "vertices_after": int(self.vertices_after),
            "seconds": float(self.seconds),
        }


@dataclass(frozen=True)
class CleaningReport:
    """What :func:`clean_mesh` changed.

    Attributes
    ----------
    name : str
        The mesh name.
    steps : tuple of StepReport
        One entry per step, in order: ``repair``, ``remove_hidden``, ``simplify``.
    self_intersection_method : str
        What step 1 did about self-intersections: ``"none"`` (there were
        none), ``"union"``, ``"remove"`` or ``"union+remove"`` (see
        :func:`repair_mesh`).
    self_intersections_before : int
        Faces that pymeshlab's self-intersection test selects once duplicate
        vertices are merged (touching faces of an unmerged triangle soup would
        all count otherwise).
    self_intersections_after_repair : int
        The same count after step 1: zero unless ``max_rounds`` was 0.
    self_intersections_after : int
        The same count on the cleaned mesh. Decimation creates some; step 3
        removes them again (up to three rounds), so this is normally 0.
    hidden_area_removed : float
        Area of the faces removed in step 2, in model units squared.
    hidden_area_fraction : float
        ``hidden_area_removed`` over the area entering step 2.
    faces_flipped : int
        Faces reversed in step 2 because they were seen mostly from behind.
    """

    name: str
    steps: tuple[StepReport, ...]
    self_intersection_method: str
    self_intersections_before: int
    self_intersections_after_repair: int
    self_intersections_after: int
    hidden_area_removed: float
    hidden_area_fraction: float
    faces_flipped: int

    @property
    def faces_before(self) -> int:
        """Faces of the input mesh."""
        return self.steps[0].faces_before

    @property
    def faces_after(self) -> int:
        """Faces of the cleaned mesh."""
        return self.steps[-1].faces_after

    @property
    def seconds(self) -> float:
        """Total time of all steps."""
        return float(sum(step.seconds for step in self.steps))

    def step(self, name: str) -> StepReport:
        """Return the entry of the step called ``name``.

        Raises
        ------
        InputError
            If there is no step of that name.
        """
        for entry in self.steps:
            if entry.name == name:
                return entry
        raise InputError(f"name: no cleaning step {name!r}; steps are {', '.join(_STEP_NAMES)}")

    def to_dict(self) -> dict[str, Any]:
        """Return the report as JSON types only (str, int, float, list, dict).

        Returns
        -------
        dict
            The attributes, with ``steps`` as a list of dicts, plus
            ``faces_before``, ``faces_after`` and ``seconds``.
        """
        return {
            "name": self.name,
            "faces_before": int(self.faces_before),
            "faces_after": int(self.faces_after),
            "seconds": float(self.seconds),
            "self_intersection_method": self.self_intersection_method,
            "self_intersections_before": int(self.self_intersections_before),
            "self_intersections_after_repair": int(self.self_intersections_after_repair),
            "self_intersections_after": int(self.self_intersections_after),
            "hidden_area_removed": float(self.hidden_area_removed),
            "hidden_area_fraction": float(self.hidden_area_fraction),
            "faces_flipped": int(self.faces_flipped),
            "steps": [step.to_dict() for step in self.steps],
        }


@dataclass(frozen=True)
class _Repaired:
    """Result of step 1 with the bookkeeping step 2 needs."""

    connected: Mesh  # after the connectivity repairs, before resolving intersections
    repaired: Mesh
    origin: NDArray[np.int64]  # face of ``connected`` each repaired face comes from, -1 if new
    method: str
    intersections_before: int
    intersections_after: int


def clean_mesh(
    mesh: Mesh,
    *,
    max_faces: int = MAX_FACES,
    self_intersections: SelfIntersectionMethod = "auto",
    max_rounds: int = 5,
    n_views: int = N_VIEWS,
    hidden_resolution: int = HIDDEN_RESOLUTION,
    orient: bool = True,
    remesh: bool = False,
) -> tuple[Mesh, CleaningReport]:
    """Clean a mesh in the paper's three steps and report what changed.

    1. :func:`repair_mesh` (connectivity and self-intersections).
    2. Remove the faces seen in none of the ``n_views`` views and turn the
       others towards the side they are seen from
       (:func:`remove_hidden_faces`). Removing intersecting faces in step 1
       can open seams through which buried parts become visible, so a face is
       also removed if the face it comes from was already hidden before the
       intersections were resolved.
    3. :func:`simplify_mesh` to at most ``max_faces`` faces.

    Parameters
    ----------
    mesh : Mesh
        The raw mesh, e.g. a ModelNet40 model.
    max_faces : int
        Face budget of the result, at least 4 (default: 10000).
    self_intersections : {"auto", "remove"}
        How step 1 resolves self-intersections (default: "auto"; see
        :func:`repair_mesh`).
    max_rounds : int
        Rounds of removing intersecting faces and closing holes (default: 5).
    n_views : int
        Views on the Fibonacci sphere for the hidden-face test (default: 1000).
    hidden_resolution : int
        Image side in pixels for the hidden-face test (default: 256).
    orient : bool
        In step 2, reverse the faces seen mostly from behind (default: True;
        see :func:`remove_hidden_faces`).
    remesh : bool
        Also remesh isotropically in step 3 (default: False).

    Returns
    -------
    cleaned : Mesh
        The cleaned mesh, with the input's name and at most ``max_faces`` faces.
    report : CleaningReport
        Sizes and seconds per step, self-intersections before and after, and
        the hidden area removed.

    Raises
    ------
    InputError
        If ``mesh`` is not a Mesh or an option is out of range.
    MissingDependencyError
        If pymeshlab is not installed.
    MeasurementError
        If a step fails or leaves no faces; the message starts with the mesh name.

    Examples
    --------
    >>> from vptoolkit.io import load_mesh
    >>> from vptoolkit.samples import sample_path
    >>> cleaned, report = clean_mesh(load_mesh(sample_path("bunny")), max_faces=2000)
    >>> cleaned.n_faces <= 2000, [step["name"] for step in report.to_dict()["steps"]]
    (True, ['repair', 'remove_hidden', 'simplify'])
    """
    _check_mesh(mesh)
    max_faces = check_int(max_faces, "max_faces", minimum=4)
    max_rounds = check_int(max_rounds, "max_rounds", minimum=0)
    n_views = check_int(n_views, "n_views", minimum=1)
    hidden_resolution = check_int(hidden_resolution, "hidden_resolution", minimum=8)
    _check_method(self_intersections)
    orient = check_bool(orient, "orient")
    remesh = check_bool(remesh, "remesh")
    ml = _pymeshlab()

    start = time.perf_counter()
    repair = _repair(ml, mesh, self_intersections, max_rounds)
    repaired = repair.repaired
    steps = [_step("repair", mesh, repaired, start)]

    start = time.perf_counter()
    pixels = two_sided_pixel_totals(repaired, n_views=n_views, resolution=hidden_resolution)
    is_hidden = pixels.sum(axis=1) == 0
    if repair.method != "none":
        is_hidden |= _hidden_before_resolving(repair, n_views, hidden_resolution)
    is_hidden = _keep_small_faces_by_seen_ones(repaired, is_hidden, hidden_resolution)
    if orient:
        is_flipped = _seen_from_behind(repaired.faces, np.where(is_hidden[:, None], 0, pixels))
        is_flipped &= ~is_hidden
    else:
        is_flipped = np.zeros(repaired.n_faces, dtype=bool)
    areas = face_areas(repaired)
    hidden_area = float(areas[is_hidden].sum())
    total_area = float(areas.sum())
    visible = _submesh(repaired, ~is_hidden, "remove_hidden", flip=is_flipped)
    steps.append(_step("remove_hidden", repaired, visible, start))

    start = time.perf_counter()
    meshes = _to_meshset(ml, visible.vertices, visible.faces, visible.name)
    _simplify(ml, meshes, mesh.name, max_faces, remesh)
    intersections_after = -1  # not known yet
    for _ in range(_AFTER_DECIMATION_ROUNDS):
        # Quadric collapses do not test for intersections and bring some back
        # (2.3 % of a raw ModelNet airplane's faces): remove them, without closing
        # holes, which would also fill the model's own openings and add faces.
        # A round that finds none has tested the mesh as it stays: no recount.
        if not _remove_intersections(ml, meshes, mesh.name, 0, step="simplify")[0]:
            intersections_after = 0
            break
    if intersections_after < 0:
        intersections_after = _count_self_intersections(meshes)
    simplified = _to_mesh(meshes, mesh.name, "simplify")
    steps.append(_step("simplify", visible, simplified, start))

    report = CleaningReport(
        name=mesh.name,
        steps=tuple(steps),
        self_intersection_method=repair.method,
        self_intersections_before=repair.intersections_before,
        self_intersections_after_repair=repair.intersections_after,
        self_intersections_after=intersections_after,
        hidden_area_removed=hidden_area,
        hidden_area_fraction=hidden_area / total_area if total_area > 0.0 else 0.0,
        faces_flipped=int(is_flipped.sum()),
    )
    return simplified, report


def repair_mesh(
    mesh: Mesh,
    *,
    self_intersections: SelfIntersectionMethod = "auto",
    max_rounds: int = 5,
) -> Mesh:
    """Step 1: fix the connectivity and resolve self-intersections.

    Connectivity, in order: remove null (zero-area) and duplicate faces, merge
    vertices closer than :data:`MERGE_TOLERANCE` bounding-box diagonals,
    remove the faces that merging made null or duplicate, drop unreferenced
    vertices, then repair non-manifold edges and vertices. On an edge shared
    by more than two faces, the faces of the smallest patches (parts of the
    mesh connected through manifold edges) are removed until two remain, so a
    stray fin goes rather than a face of the body it sticks out of;
    pymeshlab's ``meshing_repair_non_manifold_edges`` (smallest faces first)
    and ``meshing_repair_non_manifold_vertices`` (split) handle what is left.

    Self-intersections are then resolved as ``self_intersections`` says, and
    finally the faces of each manifold part are wound consistently
    (``meshing_re_orient_faces_coherently``; step 2 decides which side is out).

    Parameters
    ----------
    mesh : Mesh
        The raw mesh.
    self_intersections : {"auto", "remove"}
        ``"auto"`` (default): boolean union of the closed parts that intersect,
        then removal for whatever intersections remain. ``"remove"``: removal
        only (faster on big closed meshes, loses more surface).
    max_rounds : int
        Rounds of removing intersecting faces and closing holes (default: 5).

    Returns
    -------
    repaired : Mesh
        Same name; pymeshlab's self-intersection test selects no face (unless
        ``max_rounds`` is 0).

    Raises
    ------
    InputError
        On a bad argument.
    MeasurementError
        If a filter fails or nothing is left; the message starts with the mesh name.

    Notes
    -----
    Self-intersecting faces have area that cannot be seen, so they bias
    ``A_t`` and ``A_z``. The paper resolves them with PyMesh, which cuts faces
    along the intersection curves and keeps every piece (step 2 then drops the
    buried pieces). pymeshlab exposes such exact cutting only through its
    boolean filters, so two methods are combined:

    * **Union** (``"auto"`` only). A closed part (every edge shared by exactly
      two consistently oriented faces) that intersects something is oriented
      outward (by the sign of its volume) and all such parts are replaced by
      their boolean union (``generate_boolean_union`` of the part set with
      itself: libigl, exact predicates). This is what PyMesh does plus
      dropping the buried pieces: the visible geometry is kept exactly, up
      to rounding the exact cut points to float64 (the rare faces that this
      leaves touching go to the removal below). It is slow (about 4 s for
      10k faces, 2 min for 400k on two cores), and it refuses open surfaces.
    * **Remove.** Raw ModelNet40 models are mostly open shells and loose
      triangles, which no boolean accepts. For those, the intersecting faces
      (``compute_selection_by_self_intersections_per_face``) are removed, the
      non-manifold elements this creates are repaired and holes of up to 30
      border edges are closed where that creates no new intersection; this
      repeats for ``max_rounds`` rounds, and a last round removes any face
      still intersecting without closing, which leaves (almost) nothing
      intersecting (splitting the non-manifold vertices this creates can
      leave a handful). It is fast and pymeshlab-only, but the intersecting
      faces are lost: parts that interpenetrate end up separated by a seam
      where they met, and large removed faces may leave open holes.
      :func:`clean_mesh` makes sure that buried parts and hole fillings seen
      only through such seams still go in step 2.

    Boolean union of everything through another library (manifold3d) was not
    used: it also needs closed input, so it would not help with ModelNet.
    """
    _check_mesh(mesh)
    _check_method(self_intersections)
    max_rounds = check_int(max_rounds, "max_rounds", minimum=0)
    return _repair(_pymeshlab(), mesh, self_intersections, max_rounds).repaired


def two_sided_pixel_totals(
    mesh: Mesh,
    *,
    n_views: int = N_VIEWS,
    resolution: int = HIDDEN_RESOLUTION,
) -> NDArray[np.int64]:
    """Pixels of each face over all views, seen from its front and from its back.

    Counts with :func:`~vptoolkit.visibility.face_pixel_totals` over
    ``n_views`` directions of :func:`~vptoolkit.sphere.fibonacci_sphere`
    (back faces culled, the model framed as for the measures). Each face is
    drawn from both sides: a reversed copy sits ``1e-5`` bounding-box
    diagonals behind it. The copy is offset rather than coincident, so depth
    ties cannot hide either side.

    Parameters
    ----------
    mesh : Mesh
        The mesh to test.
    n_views : int
        Number of view directions (default: 1000, as in the paper).
    resolution : int
        Image side in pixels (default: 256). A face smaller than a pixel is
        still hit in some of the many slightly shifted views; lower values are
        faster but may miss small faces in deep concavities.

    Returns
    -------
    pixels : (n_faces, 2) int64
        Column 0: pixels where the face is seen from the side its normal
        points to (the front); column 1: pixels where it is seen from behind.
        Zero-area faces are never drawn and have ``(0, 0)``.

    Raises
    ------
    InputError
        On a bad argument.
    """
    _check_mesh(mesh)
    n_views = check_int(n_views, "n_views", minimum=1)
    resolution = check_int(resolution, "resolution", minimum=8)
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
    totals = face_pixel_totals(two_sided, fibonacci_sphere(n_views), resolution=resolution)
    return np.stack([totals[:n_faces], totals[n_faces:]], axis=1).astype(np.int64)


def hidden_faces(
    mesh: Mesh,
    *,
    n_views: int = N_VIEWS,
    resolution: int = HIDDEN_RESOLUTION,
) -> NDArray[np.bool_]:
    """Find the faces seen in none of the views, from either side.

    Raw models often have inverted or inconsistently oriented faces, which
    back-face culling would hide in every view, so a face counts as seen if
    its front or its back covers a pixel (:func:`two_sided_pixel_totals`).

    Parameters
    ----------
    mesh : Mesh
        The mesh to test.
    n_views : int
        Number of view directions (default: 1000).
    resolution : int
        Image side in pixels (default: 256).

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
    """
    pixels = two_sided_pixel_totals(mesh, n_views=n_views, resolution=resolution)
    return _keep_small_faces_by_seen_ones(mesh, pixels.sum(axis=1) == 0, resolution)


def remove_hidden_faces(
    mesh: Mesh,
    *,
    n_views: int = N_VIEWS,
    resolution: int = HIDDEN_RESOLUTION,
    orient: bool = True,
) -> Mesh:
    """Step 2: drop the faces seen in none of the views and orient the rest.

    A face is dropped if neither side covers a pixel in any view
    (:func:`hidden_faces`). With ``orient``, the faces are turned towards the
    side they are seen from, because raw models often mix inward and outward
    faces and the measures cull back faces. The vote is per patch of
    consistently wound faces joined by manifold edges: a patch whose faces
    cover more pixels from behind than from the front is reversed as a whole.
    A consistently outward-oriented mesh is left as it is; a triangle soup
    is oriented face by face.

    Parameters
    ----------
    mesh : Mesh
        The repaired mesh.
    n_views : int
        Number of view directions (default: 1000).
    resolution : int
        Image side in pixels (default: 256).
    orient : bool
        Reverse the faces seen mostly from behind (default: True).

    Returns
    -------
    visible : Mesh
        The faces seen from some view, without unreferenced vertices.

    Raises
    ------
    MeasurementError
        If no face is seen; the message starts with the mesh name.
    """
    orient = check_bool(orient, "orient")
    pixels = two_sided_pixel_totals(mesh, n_views=n_views, resolution=resolution)
    is_hidden = _keep_small_faces_by_seen_ones(mesh, pixels.sum(axis=1) == 0, resolution)
    is_flipped = _seen_from_behind(mesh.faces, pixels) if orient else None
    return _submesh(mesh, ~is_hidden, "remove_hidden", flip=is_flipped)


def simplify_mesh(mesh: Mesh, *, max_faces: int = MAX_FACES, remesh: bool = False) -> Mesh:
    """Step 3: decimate to at most ``max_faces`` faces, optionally remesh.

    Quadric edge-collapse decimation (``meshing_decimation_quadric_edge_collapse``)
    runs only if the mesh has more than ``max_faces`` faces. It keeps the
    silhouette: boundary edges are preserved, collapses that flip a face
    normal are refused, planar regions get an extra quadric so that they
    simplify cleanly, vertices move to the quadric optimum, and a quality
    threshold of 0.3 avoids slivers. If those constraints stop it above the
    budget, it runs again without boundary and normal preservation, then with
    a plain quadric, before giving up.

    Quadric decimation does not check for intersections: on models with thin
    parts close together (wings, seams left by step 1) it can create some.
    :func:`clean_mesh` removes those faces afterwards (without closing the
    holes, which would also fill the model's own openings);
    :func:`simplify_mesh` alone leaves them.

    With ``remesh=True`` an isotropic explicit remeshing (10 iterations,
    creases above 30 degrees kept, vertices reprojected onto the surface)
    then evens out the triangles, aiming at about 80% of ``max_faces``;
    decimation runs again if it overshoots.

    Parameters
    ----------
    mesh : Mesh
        The mesh to simplify.
    max_faces : int
        Face budget, at least 4 (default: 10000).
    remesh : bool
        Also remesh isotropically (default: False).

    Returns
    -------
    simplified : Mesh
        At most ``max_faces`` faces; the input unchanged if already within
        budget and ``remesh`` is False.

    Raises
    ------
    MeasurementError
        If the budget cannot be met or a filter fails; the message starts with
        the mesh name.
    """
    _check_mesh(mesh)
    max_faces = check_int(max_faces, "max_faces", minimum=4)
    remesh = check_bool(remesh, "remesh")
    if mesh.n_faces <= max_faces and not remesh:
        return mesh
    ml = _pymeshlab()
    meshes = _to_meshset(ml, mesh.vertices, mesh.faces, mesh.name)
    _simplify(ml, meshes, mesh.name, max_faces, remesh)
    return _to_mesh(meshes, mesh.name, "simplify")


def count_self_intersections(mesh: Mesh) -> int:
    """Count the faces that intersect another face of the mesh.

    Uses pymeshlab's ``compute_selection_by_self_intersections_per_face``,
    which tests the pairs of nearby faces that share no vertex. Faces of a
    triangle soup that merely touch count too: repair (merge) first for a
    meaningful number.

    Parameters
    ----------
    mesh : Mesh
        The mesh to test.

    Returns
    -------
    count : int
        Number of faces selected as self-intersecting.
    """
    _check_mesh(mesh)
    ml = _pymeshlab()
    return _count_self_intersections(_to_meshset(ml, mesh.vertices, mesh.faces, mesh.name))


# ---------------------------------------------------------------- checks


def _pymeshlab() -> ModuleType:
    ml = require("pymeshlab", extra="clean")
    global _is_flag_state_settled
    if not _is_flag_state_settled:
        _settle_flag_state(ml)
        _is_flag_state_settled = True
    return ml


_is_flag_state_settled = False
_SETTLE_CALLS = 64


def _settle_flag_state(ml: ModuleType) -> None:
    """Put pymeshlab's process-wide face flag state where it stays, before any cleaning.

    vcglib hands out "user bit" face flags from one counter per process.
    ``meshing_close_holes`` and ``meshing_re_orient_faces_coherently`` take
    bits they never give back, so after a few calls the counter runs out and
    stays out; from then on the self-intersection test checks each pair of
    faces both ways (instead of once), and selects a few more faces. Left
    alone, a model's cleaning would depend on how many models the same process
    cleaned before it (a worker pool, a Dask worker, a resumed build). Running
    the leaking filter on a tiny open box well past the counter's 32 bits at
    the first use of pymeshlab makes every model see the final state, so the
    same mesh is always cleaned the same way.
    """
    vertices = np.array(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
        dtype=np.float64,
    )
    faces = np.array(
        [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5],
         [0, 5, 4], [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6]],
        dtype=np.int32,
    )
    for _ in range(_SETTLE_CALLS):
        meshes = ml.MeshSet(verbose=False)
        meshes.add_mesh(ml.Mesh(vertex_matrix=vertices, face_matrix=faces), "settle")
        try:
            meshes.apply_filter("meshing_re_orient_faces_coherently")
            meshes.apply_filter("meshing_close_holes", maxholesize=_HOLE_EDGES)
        except ml.PyMeshLabException:  # pragma: no cover - a pymeshlab without these filters
            return


def _check_mesh(mesh: Mesh) -> None:
    if not isinstance(mesh, Mesh):
        raise InputError(f"mesh: expected a vptoolkit Mesh, got {type(mesh).__name__}")


def _check_method(method: str) -> None:
    if method not in ("auto", "remove"):
        raise InputError(f"self_intersections: expected 'auto' or 'remove', got {method!r}")


# ---------------------------------------------------------------- pymeshlab plumbing


def _to_meshset(
    ml: ModuleType,
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    name: str,
    origin: NDArray[np.int64] | None = None,
) -> pymeshlab.MeshSet:
    """A MeshSet of one mesh; ``origin + 1`` rides along as face quality."""
    if origin is None:
        origin = np.arange(len(faces), dtype=np.int64)
    meshes = ml.MeshSet(verbose=False)
    meshes.add_mesh(
        ml.Mesh(
            vertex_matrix=np.ascontiguousarray(vertices, dtype=np.float64),
            face_matrix=np.ascontiguousarray(faces, dtype=np.int32),
            f_scalar_array=(origin + 1).astype(np.float64),
        ),
        name,
    )
    return meshes


def _arrays(
    meshes: pymeshlab.MeshSet,
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """Vertices, faces and face origins (-1 for faces pymeshlab created).

    Each face is rotated to start at its smallest vertex index (same winding):
    some filters (the boolean union's multi-threaded remeshing) return the
    same triangles starting at a vertex that varies from run to run, and later
    filters and the point sampling depend on that order.
    """
    current = meshes.current_mesh()
    current.compact()
    vertices = np.array(current.vertex_matrix(), dtype=np.float64).reshape(-1, 3)
    faces = _canonical_rotation(np.array(current.face_matrix(), dtype=np.int64).reshape(-1, 3))
    if current.has_face_scalar() and len(faces):
        origin = np.rint(np.asarray(current.face_scalar_array())).astype(np.int64) - 1
    else:
        origin = np.full(len(faces), -1, dtype=np.int64)
    return vertices, faces, origin


def _canonical_rotation(faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """Rotate each face ``(n_faces, 3)`` to start at its smallest index, keeping its winding."""
    if len(faces) == 0:
        return faces
    first = np.argmin(faces, axis=1)
    rows = np.arange(len(faces))[:, None]
    return np.ascontiguousarray(faces[rows, (first[:, None] + np.arange(3)) % 3])


def _to_mesh(meshes: pymeshlab.MeshSet, name: str, step: str) -> Mesh:
    vertices, faces, _ = _arrays(meshes)
    if len(faces) == 0:
        raise MeasurementError(f"{name}: cleaning step {step!r} left no faces")
    return Mesh(vertices, faces, name=name)


def _apply(
    meshes: pymeshlab.MeshSet, name: str, step: str, filter_name: str, **params: Any
) -> None:
    ml = _pymeshlab()
    try:
        meshes.apply_filter(filter_name, **params)
    except ml.PyMeshLabException as err:
        raise MeasurementError(
            f"{name}: {step}: pymeshlab {filter_name} failed: {one_line(err)}"
        ) from err


def _n_faces(meshes: pymeshlab.MeshSet) -> int:
    return int(meshes.current_mesh().face_number())


def _refresh(meshes: pymeshlab.MeshSet, name: str) -> None:
    """Rebuild the current mesh from its arrays, keeping face origins.

    pymeshlab's self-intersection test can disagree with itself on a mesh
    edited by earlier filters (stale adjacency); a rebuilt mesh gives the same
    answer as a freshly loaded one.
    """
    ml = _pymeshlab()
    vertices, faces, origin = _arrays(meshes)
    meshes.clear()
    meshes.add_mesh(
        ml.Mesh(
            vertex_matrix=vertices,
            face_matrix=faces.astype(np.int32),
            f_scalar_array=(origin + 1).astype(np.float64),
        ),
        name,
    )


def _intersecting_faces(meshes: pymeshlab.MeshSet) -> NDArray[np.bool_]:
    """Per-face flag of pymeshlab's self-intersection test (rebuilds the mesh first)."""
    _refresh(meshes, meshes.current_mesh().label())
    current = meshes.current_mesh()
    if current.face_number() == 0:
        return np.zeros(0, dtype=bool)
    meshes.apply_filter("compute_selection_by_self_intersections_per_face")
    selected = np.array(meshes.current_mesh().face_selection_array(), dtype=bool)
    meshes.apply_filter("set_selection_none")
    return selected


def _count_self_intersections(meshes: pymeshlab.MeshSet) -> int:
    return int(_intersecting_faces(meshes).sum())


# ---------------------------------------------------------------- step 1


def _repair(ml: ModuleType, mesh: Mesh, method: str, max_rounds: int) -> _Repaired:
    name = mesh.name
    meshes = _to_meshset(ml, mesh.vertices, mesh.faces, name)
    _apply(meshes, name, "repair", "meshing_remove_null_faces")
    _apply(meshes, name, "repair", "meshing_remove_duplicate_faces")
    _merge_close_vertices(ml, meshes, name)

    vertices, faces, _ = _arrays(meshes)
    if len(faces) == 0:
        raise MeasurementError(f"{name}: cleaning step 'repair' left no faces")
    keep = _keep_major_faces_on_non_manifold_edges(vertices, faces)
    meshes = _to_meshset(ml, vertices, faces[keep], name)
    _repair_non_manifold(meshes, name, "repair")

    vertices, faces, _ = _arrays(meshes)
    connected = Mesh(vertices, faces, name=name)
    meshes = _to_meshset(ml, vertices, faces, name)  # origins index ``connected``
    is_intersecting = _intersecting_faces(meshes)
    intersections_before = int(is_intersecting.sum())
    used = []
    intersections_after = 0 if not intersections_before else -1  # -1: not known yet
    if intersections_before and method == "auto":
        if _union_closed_parts(ml, meshes, name, is_intersecting):
            used.append("union")
    if intersections_before:
        found, last = _remove_intersections(ml, meshes, name, max_rounds)
        if found:
            used.append("remove")
        if last == 0:
            intersections_after = 0
    try:
        # Consistent winding within each manifold part; step 2 picks the side.
        meshes.apply_filter("meshing_re_orient_faces_coherently")
    except ml.PyMeshLabException:
        pass  # a non-orientable part: step 2 then orients patch by patch
    vertices, faces, origin = _arrays(meshes)
    if len(faces) == 0:
        raise MeasurementError(f"{name}: cleaning step 'repair' left no faces")
    return _Repaired(
        connected=connected,
        repaired=Mesh(vertices, faces, name=name),
        origin=origin,
        method="+".join(used) if used else "none",
        intersections_before=intersections_before,
        # Reorienting faces does not change which intersect: a test that found
        # none on this mesh's geometry stands.
        intersections_after=(
            intersections_after if intersections_after >= 0 else _count_self_intersections(meshes)
        ),
    )


def _merge_close_vertices(ml: ModuleType, meshes: pymeshlab.MeshSet, name: str) -> None:
    """Merge vertices closer than MERGE_TOLERANCE diagonals, then drop what that degenerates."""
    _apply(
        meshes,
        name,
        "repair",
        "meshing_merge_close_vertices",
        threshold=ml.PercentageValue(100.0 * MERGE_TOLERANCE),
    )
    _remove_null_and_duplicates(meshes, name, "repair")


def _remove_null_and_duplicates(meshes: pymeshlab.MeshSet, name: str, step: str) -> None:
    _apply(meshes, name, step, "meshing_remove_duplicate_faces")
    _apply(meshes, name, step, "meshing_remove_null_faces")
    _apply(meshes, name, step, "meshing_remove_unreferenced_vertices")


def _repair_non_manifold(meshes: pymeshlab.MeshSet, name: str, step: str) -> None:
    """Null and duplicate faces, then non-manifold edges and vertices, until stable."""
    _remove_null_and_duplicates(meshes, name, step)
    for _ in range(4):
        before = (_n_faces(meshes), int(meshes.current_mesh().vertex_number()))
        _apply(meshes, name, step, "meshing_repair_non_manifold_edges", method="Remove Faces")
        _apply(
            meshes,
            name,
            step,
            "meshing_repair_non_manifold_vertices",
            vertdispratio=_SPLIT_DISPLACEMENT,
        )
        _remove_null_and_duplicates(meshes, name, step)
        if (_n_faces(meshes), int(meshes.current_mesh().vertex_number())) == before:
            break
    if _n_faces(meshes) == 0:
        raise MeasurementError(f"{name}: cleaning step {step!r} left no faces")


def _undirected_edges(faces: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Edge id of each face side ``(n_faces, 3)`` and the number of faces on each edge."""
    sides = np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1)
    sides = np.sort(sides, axis=2).reshape(-1, 2)
    keys = sides[:, 0] * (int(faces.max()) + 1) + sides[:, 1]
    _, edge_id, counts = np.unique(keys, return_inverse=True, return_counts=True)
    return edge_id.reshape(-1, 3).astype(np.int64), counts.astype(np.int64)


def _union_find(
    n_items: int, first: NDArray[np.int64], second: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Component label ``0 .. k-1`` of each item joined by the pairs (hook and pointer-jump)."""
    parent = np.arange(n_items, dtype=np.int64)
    while len(first):
        root_first, root_second = parent[first], parent[second]
        differ = root_first != root_second
        if not differ.any():
            break
        low = np.minimum(root_first[differ], root_second[differ])
        high = np.maximum(root_first[differ], root_second[differ])
        np.minimum.at(parent, high, low)
        while True:
            grand = parent[parent]
            if np.array_equal(grand, parent):
                break
            parent = grand
    return np.unique(parent, return_inverse=True)[1].astype(np.int64).reshape(-1)


def _keep_major_faces_on_non_manifold_edges(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> NDArray[np.bool_]:
    """On each edge with more than two faces, keep the two from the largest patches."""
    edge_id, counts = _undirected_edges(faces)
    keep = np.ones(len(faces), dtype=bool)
    if not (counts > 2).any():
        return keep
    # Patches: faces joined through manifold edges (exactly two faces).
    flat_edges = edge_id.ravel()
    flat_faces = np.repeat(np.arange(len(faces), dtype=np.int64), 3)
    manifold = counts[flat_edges] == 2
    order = np.argsort(flat_edges[manifold], kind="stable")
    paired = flat_faces[manifold][order].reshape(-1, 2)
    patch = _union_find(len(faces), paired[:, 0], paired[:, 1])
    corners = vertices[faces]
    areas = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    patch_area = np.bincount(patch, weights=areas)
    # Faces on each non-manifold edge, largest patch first (then larger face).
    crowded = counts[flat_edges] > 2
    edges, on_faces = flat_edges[crowded], flat_faces[crowded]
    order = np.lexsort((-areas[on_faces], -patch_area[patch[on_faces]], edges))
    edges, on_faces = edges[order], on_faces[order]
    rank = np.arange(len(edges)) - np.searchsorted(edges, edges, side="left")
    keep[on_faces[rank >= 2]] = False
    return keep


def _hidden_before_resolving(repair: _Repaired, n_views: int, resolution: int) -> NDArray[np.bool_]:
    """Repaired faces that were hidden before the self-intersections were resolved.

    Resolving intersections by removal opens seams through which buried parts
    can be seen. This renders the mesh as it was before (``connected``, whose
    intersecting faces still close the seams) together with the faces step 1
    created (hole fillings), and maps the result onto the repaired faces:
    a kept face inherits the flag of the face it comes from, a new face gets
    its own. New faces come last, so where one exactly covers a removed face
    the rasteriser's depth tie goes to the new face.
    """
    connected, repaired, origin = repair.connected, repair.repaired, repair.origin
    is_new = origin < 0
    scene = Mesh(
        np.vstack([connected.vertices, repaired.vertices]),
        np.vstack([connected.faces, repaired.faces[is_new] + connected.n_vertices]),
        name=connected.name,
    )
    pixels = two_sided_pixel_totals(scene, n_views=n_views, resolution=resolution)
    was_hidden = pixels.sum(axis=1) == 0
    is_hidden = np.zeros(repaired.n_faces, dtype=bool)
    is_hidden[~is_new] = was_hidden[origin[~is_new]]
    is_hidden[is_new] = was_hidden[connected.n_faces :]
    return is_hidden


def _keep_small_faces_by_seen_ones(
    mesh: Mesh, is_hidden: NDArray[np.bool_], resolution: int, *, rings: int = 2
) -> NDArray[np.bool_]:
    """Count sub-pixel unseen faces next to seen ones as seen (see :func:`hidden_faces`)."""
    if not is_hidden.any() or is_hidden.all():
        return is_hidden
    camera = Camera()
    _, diagonal = bounding_frame(mesh)
    distance = camera.distance_factor * diagonal
    pixel = 2.0 * distance * math.tan(math.radians(camera.fov_deg) / 2.0) / resolution
    is_small = face_areas(mesh) < pixel * pixel
    candidates = is_hidden & is_small
    if not candidates.any():
        return is_hidden
    edge_id, counts = _undirected_edges(mesh.faces)
    is_hidden = is_hidden.copy()
    for _ in range(rings):
        edge_seen = np.zeros(len(counts), dtype=bool)
        edge_seen[edge_id[~is_hidden].ravel()] = True
        rescued = candidates & is_hidden & edge_seen[edge_id].any(axis=1)
        if not rescued.any():
            break
        is_hidden[rescued] = False
    return is_hidden


def _coherent_patches(faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """Label faces joined through manifold edges that they traverse in opposite directions."""
    sides = np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1).reshape(-1, 2)
    is_forward = sides[:, 0] < sides[:, 1]
    edge_id, counts = _undirected_edges(faces)
    flat_edges = edge_id.ravel()
    flat_faces = np.repeat(np.arange(len(faces), dtype=np.int64), 3)
    manifold = counts[flat_edges] == 2
    order = np.argsort(flat_edges[manifold], kind="stable")
    paired_faces = flat_faces[manifold][order].reshape(-1, 2)
    paired_forward = is_forward[manifold][order].reshape(-1, 2)
    coherent = paired_forward[:, 0] != paired_forward[:, 1]
    return _union_find(len(faces), paired_faces[coherent, 0], paired_faces[coherent, 1])


def _seen_from_behind(faces: NDArray[np.int64], pixels: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Faces of the coherent patches that cover more pixels from behind than from the front."""
    patch = _coherent_patches(faces)
    front = np.bincount(patch, weights=pixels[:, 0])
    back = np.bincount(patch, weights=pixels[:, 1])
    return np.asarray((back > front)[patch], dtype=bool)


def _closed_components(
    faces: NDArray[np.int64], n_vertices: int
) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Component of each face, and whether each component is closed and consistently oriented."""
    first = faces.ravel()
    second = np.roll(faces, -1, axis=1).ravel()
    label = _union_find(n_vertices, first, second)[faces[:, 0]]
    n_components = int(label.max()) + 1
    key_width = n_vertices
    forward = first * key_width + second
    backward = second * key_width + first
    unique, counts = np.unique(forward, return_counts=True)
    position = np.clip(np.searchsorted(unique, backward), 0, len(unique) - 1)
    has_twin = unique[position] == backward
    is_good = has_twin & (counts[np.searchsorted(unique, forward)] == 1)
    is_good &= np.where(has_twin, counts[position] == 1, False)
    face_good = is_good.reshape(-1, 3).all(axis=1)
    bad_count = np.bincount(label, weights=~face_good, minlength=n_components)
    return label, bad_count == 0


def _union_closed_parts(
    ml: ModuleType, meshes: pymeshlab.MeshSet, name: str, is_intersecting: NDArray[np.bool_]
) -> bool:
    """Replace the intersecting closed parts by their boolean union; False if none or it failed."""
    vertices, faces, origin = _arrays(meshes)
    label, is_closed = _closed_components(faces, len(vertices))
    involved = np.zeros(len(is_closed), dtype=bool)
    involved[label[is_intersecting]] = True
    chosen = (is_closed & involved)[label]
    if not chosen.any():
        return False
    # Orient each chosen part outward: the union reads orientation as inside/outside.
    part_faces = faces[chosen].copy()
    part_label = label[chosen]
    corners = vertices[part_faces] - vertices.mean(axis=0)
    volumes = np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2]))
    is_inverted = np.bincount(part_label, weights=volumes)[part_label] < 0
    part_faces[is_inverted] = part_faces[is_inverted][:, ::-1]
    union = _to_meshset(ml, vertices, part_faces, name, origin[chosen])
    try:
        union.apply_filter(
            "generate_boolean_union", first_mesh=0, second_mesh=0, transfer_face_quality=True
        )
    except ml.PyMeshLabException:
        return False  # e.g. degenerate input; the removal method takes over
    union_vertices, union_faces, union_origin = _arrays(union)
    if len(union_faces) == 0:
        return False
    rest = faces[~chosen]
    merged_vertices = np.vstack([vertices, union_vertices])
    merged_faces = np.vstack([rest, union_faces + len(vertices)])
    merged_origin = np.concatenate([origin[~chosen], union_origin])
    meshes.clear()
    meshes.add_mesh(
        ml.Mesh(
            vertex_matrix=merged_vertices,
            face_matrix=merged_faces.astype(np.int32),
            f_scalar_array=(merged_origin + 1).astype(np.float64),
        ),
        name,
    )
    _merge_close_vertices(ml, meshes, name)
    _repair_non_manifold(meshes, name, "repair")
    return True


def _remove_intersections(
    ml: ModuleType, meshes: pymeshlab.MeshSet, name: str, max_rounds: int, *,
    step: str = "repair",
) -> tuple[int, int]:
    """Remove intersecting faces in rounds.

    Returns the faces the first test found and those the last test found,
    ``-1`` if faces were removed after the last test. Each test is the one
    :func:`_count_self_intersections` makes on the mesh as it then is (rebuilt
    first), so callers need not count before or after.
    """
    found = 0
    last = -1
    for round_index in range(max_rounds + 1):
        _refresh(meshes, name)
        _apply(meshes, name, step, "compute_selection_by_self_intersections_per_face")
        selected = int(meshes.current_mesh().selected_face_number())
        if round_index == 0:
            found = selected
        if selected == 0:
            last = 0
            break
        _apply(meshes, name, step, "meshing_remove_selected_faces")
        _repair_non_manifold(meshes, name, step)
        if round_index == max_rounds:
            break  # the last round only removes
        try:
            meshes.apply_filter(
                "meshing_close_holes",
                maxholesize=_HOLE_EDGES,
                selected=False,
                newfaceselected=False,
                selfintersection=True,
                refinehole=False,
            )
        except ml.PyMeshLabException:
            pass  # hole filling needs a manifold border; leave such holes open
        _repair_non_manifold(meshes, name, step)
    _apply(meshes, name, step, "set_selection_none")
    return found, last


# ---------------------------------------------------------------- step 3


_DECIMATION_PASSES: tuple[dict[str, Any], ...] = (
    # Keep the silhouette: boundaries, normals, planar regions, no slivers.
    {"qualitythr": 0.3, "preserveboundary": True, "boundaryweight": 1.0,
     "preservenormal": True, "planarquadric": True, "planarweight": 0.001},
    # Boundary or normal checks blocked further collapses: relax them.
    {"qualitythr": 0.3, "preserveboundary": False, "preservenormal": False,
     "planarquadric": True, "planarweight": 0.001},
    {"qualitythr": 0.0, "preserveboundary": False, "preservenormal": False,
     "planarquadric": False},
)


def _simplify(
    ml: ModuleType, meshes: pymeshlab.MeshSet, name: str, max_faces: int, remesh: bool
) -> None:
    _decimate(meshes, name, max_faces)
    if remesh:
        vertices, faces, _ = _arrays(meshes)
        area = float(face_areas(Mesh(vertices, faces, name=name)).sum())
        # An equilateral triangle of side L has area sqrt(3)/4 L^2.
        target_length = math.sqrt(4.0 * area / (math.sqrt(3.0) * 0.8 * max_faces))
        _apply(
            meshes,
            name,
            "simplify",
            "meshing_isotropic_explicit_remeshing",
            iterations=10,
            targetlen=ml.PureValue(target_length),
            featuredeg=30.0,
            checksurfdist=True,
            reprojectflag=True,
        )
        _repair_non_manifold(meshes, name, "simplify")
        _decimate(meshes, name, max_faces)
    if _n_faces(meshes) > max_faces:
        raise MeasurementError(
            f"{name}: simplify: decimation stopped at {_n_faces(meshes)} faces, "
            f"above max_faces={max_faces}"
        )


def _decimate(meshes: pymeshlab.MeshSet, name: str, max_faces: int) -> None:
    for params in _DECIMATION_PASSES:
        if _n_faces(meshes) <= max_faces:
            return
        _apply(
            meshes,
            name,
            "simplify",
            "meshing_decimation_quadric_edge_collapse",
            targetfacenum=max_faces,
            preservetopology=False,
            optimalplacement=True,
            autoclean=True,
            **params,
        )
        _repair_non_manifold(meshes, name, "simplify")


# ---------------------------------------------------------------- helpers


def _submesh(
    mesh: Mesh, keep: NDArray[np.bool_], step: str, *, flip: NDArray[np.bool_] | None = None
) -> Mesh:
    """The kept faces (reversed where ``flip``) without unreferenced vertices."""
    if not keep.any():
        raise MeasurementError(f"{mesh.name}: cleaning step {step!r} left no faces")
    faces = mesh.faces.copy()
    if flip is not None:
        faces[flip] = faces[flip][:, ::-1]
    faces = faces[keep]
    used = np.unique(faces)
    remap = np.zeros(mesh.n_vertices, dtype=np.int64)
    remap[used] = np.arange(len(used), dtype=np.int64)
    return Mesh(mesh.vertices[used], remap[faces], name=mesh.name)


def _step(name: str, before: Mesh, after: Mesh, start: float) -> StepReport:
    return StepReport(
        name=name,
        faces_before=before.n_faces,
        faces_after=after.n_faces,
        vertices_before=before.n_vertices,
        vertices_after=after.n_vertices,
        seconds=time.perf_counter() - start,
    )
