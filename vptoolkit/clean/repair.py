"""Step 1 of :mod:`vptoolkit.clean`: repair connectivity and self-intersections.

Owns :func:`repair_mesh` (null and duplicate faces, merging close vertices,
non-manifold edges and vertices, then resolving self-intersections by boolean
union of closed parts and by removal), :func:`count_self_intersections`,
:data:`MERGE_TOLERANCE`, :data:`SelfIntersectionMethod` and the step-1 result
(:class:`RepairedMesh`), a mesh that carries what step 2 needs to see through
the seams that removing intersecting faces opened.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Literal, cast

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import check_int
from vptoolkit.clean._meshlab import (
    HOLE_EDGES,
    count_intersecting_faces,
    intersecting_faces,
    intersecting_faces_of,
    load_pymeshlab,
    pymeshlab_mesh,
    refresh,
    remove_null_and_duplicates,
    repair_non_manifold,
    run_filter,
    select_faces,
    to_arrays,
    to_meshset,
)
from vptoolkit.clean.topology import (
    closed_components,
    faces_near,
    keep_major_faces_on_non_manifold_edges,
)
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.mesh import Mesh, MeshLike, as_mesh

if TYPE_CHECKING:
    import pymeshlab

MERGE_TOLERANCE = 1e-6
"""Vertices closer than this fraction of the bounding-box diagonal are merged."""

SelfIntersectionMethod = Literal["auto", "remove"]
"""How :func:`repair_mesh` resolves self-intersections (see its Notes)."""


@dataclass(frozen=True, eq=False, repr=False, kw_only=True)
class RepairedMesh(Mesh):
    """The mesh :func:`repair_mesh` returns: a :class:`~vptoolkit.mesh.Mesh` and what step 1 did.

    Attributes
    ----------
    method : str
        What was done about self-intersections: ``"none"`` (there were
        none), ``"union"``, ``"remove"`` or ``"union+remove"``.
    intersections_before, intersections_after : int
        Faces pymeshlab's self-intersection test selects once duplicate
        vertices are merged, and on the repaired mesh.
    connected : Mesh
        The mesh after the connectivity repairs, before the intersections
        were resolved.
    origin : (n_faces,) int64
        Face of ``connected`` each face comes from, -1 for a face step 1
        created (a hole filling).
    """

    method: str
    intersections_before: int
    intersections_after: int
    connected: Mesh
    origin: NDArray[np.int64]


def repair_mesh(
    mesh: MeshLike,
    *,
    self_intersections: SelfIntersectionMethod = "auto",
    max_rounds: int = 5,
) -> RepairedMesh:
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
    mesh : MeshLike
        The raw mesh.
    self_intersections : {"auto", "remove"}
        ``"auto"`` (default): boolean union of the closed parts that intersect,
        then removal for whatever intersections remain. ``"remove"``: removal
        only (faster on big closed meshes, loses more surface).
    max_rounds : int
        Rounds of removing intersecting faces and closing holes (default: 5).

    Returns
    -------
    repaired : RepairedMesh
        Same name; pymeshlab's self-intersection test selects no face (unless
        ``max_rounds`` is 0). Pass it to
        :func:`~vptoolkit.clean.hidden.remove_hidden_faces` as it is: step 2
        then also drops the faces seen only through the seams of removed
        intersecting faces.

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
    mesh = as_mesh(mesh)
    check_method(self_intersections)
    max_rounds = check_int(max_rounds, "max_rounds", minimum=0)
    return _repair(load_pymeshlab(), mesh, self_intersections, max_rounds)


def count_self_intersections(mesh: MeshLike) -> int:
    """Count the faces that intersect another face of the mesh.

    Uses pymeshlab's ``compute_selection_by_self_intersections_per_face``,
    which tests the pairs of nearby faces that share no vertex. Faces of a
    triangle soup that merely touch count too: repair (merge) first for a
    meaningful number.

    Parameters
    ----------
    mesh : MeshLike
        The mesh to test.

    Returns
    -------
    count : int
        Number of faces selected as self-intersecting.
    """
    mesh = as_mesh(mesh)
    ml = load_pymeshlab()
    return count_intersecting_faces(to_meshset(ml, mesh.vertices, mesh.faces, mesh.name))


def check_method(method: str) -> None:
    if method not in ("auto", "remove"):
        raise InputError(f"self_intersections: expected 'auto' or 'remove', got {method!r}")


def _repair(ml: ModuleType, mesh: Mesh, method: str, max_rounds: int) -> RepairedMesh:
    name = mesh.name
    meshes = to_meshset(ml, mesh.vertices, mesh.faces, name)
    run_filter(meshes, name, "repair", "meshing_remove_null_faces")
    run_filter(meshes, name, "repair", "meshing_remove_duplicate_faces")
    _merge_close_vertices(ml, meshes, name)

    vertices, faces, _ = to_arrays(meshes)
    if len(faces) == 0:
        raise MeasurementError(f"{name}: cleaning step 'repair' left no faces")
    keep = keep_major_faces_on_non_manifold_edges(vertices, faces)
    meshes = to_meshset(ml, vertices, faces[keep], name)
    repair_non_manifold(meshes, name, "repair")

    vertices, faces, _ = to_arrays(meshes)
    connected = Mesh(vertices, faces, name=name)
    meshes = to_meshset(ml, vertices, faces, name)  # origins index ``connected``
    is_intersecting = intersecting_faces(meshes)
    intersections_before = int(is_intersecting.sum())
    used = []
    intersections_after = 0
    first_test: NDArray[np.bool_] | None = is_intersecting  # the mesh as it is now
    if intersections_before and method == "auto":
        if _union_closed_parts(ml, meshes, name, is_intersecting):
            used.append("union")
            first_test = None
    if intersections_before:
        found, intersections_after = remove_intersections(
            ml, meshes, name, max_rounds, first_test=first_test
        )
        if found:
            used.append("remove")
    try:
        # Consistent winding within each manifold part; step 2 picks the side.
        meshes.apply_filter("meshing_re_orient_faces_coherently")
    except ml.PyMeshLabException:
        pass  # a non-orientable part: step 2 then orients patch by patch
    vertices, faces, origin = to_arrays(meshes)
    if len(faces) == 0:
        raise MeasurementError(f"{name}: cleaning step 'repair' left no faces")
    return RepairedMesh(
        vertices,
        faces,
        name,
        connected=connected,
        origin=origin,
        method="+".join(used) if used else "none",
        intersections_before=intersections_before,
        # Reorienting faces does not change which intersect: the last test,
        # on this mesh's geometry, stands.
        intersections_after=intersections_after,
    )


def _merge_close_vertices(ml: ModuleType, meshes: pymeshlab.MeshSet, name: str) -> None:
    """Merge vertices closer than MERGE_TOLERANCE diagonals, then drop what that degenerates."""
    run_filter(
        meshes,
        name,
        "repair",
        "meshing_merge_close_vertices",
        threshold=ml.PercentageValue(100.0 * MERGE_TOLERANCE),
    )
    remove_null_and_duplicates(meshes, name, "repair")


def _union_closed_parts(
    ml: ModuleType, meshes: pymeshlab.MeshSet, name: str, is_intersecting: NDArray[np.bool_]
) -> bool:
    """Replace the intersecting closed parts by their boolean union; False if none or it failed."""
    vertices, faces, origin = to_arrays(meshes)
    label, is_closed = closed_components(faces, len(vertices))
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
    union = to_meshset(ml, vertices, part_faces, name, origin[chosen])
    try:
        union.apply_filter(
            "generate_boolean_union", first_mesh=0, second_mesh=0, transfer_face_quality=True
        )
    except ml.PyMeshLabException:
        return False  # e.g. degenerate input; the removal method takes over
    union_vertices, union_faces, union_origin = to_arrays(union)
    if len(union_faces) == 0:
        return False
    rest = faces[~chosen]
    merged_vertices = np.vstack([vertices, union_vertices])
    merged_faces = np.vstack([rest, union_faces + len(vertices)])
    merged_origin = np.concatenate([origin[~chosen], union_origin])
    meshes.clear()
    meshes.add_mesh(pymeshlab_mesh(ml, merged_vertices, merged_faces, merged_origin), name)
    _merge_close_vertices(ml, meshes, name)
    repair_non_manifold(meshes, name, "repair")
    return True


def remove_intersections(
    ml: ModuleType, meshes: pymeshlab.MeshSet, name: str, max_rounds: int, *,
    step: str = "repair", close_holes: bool = True,
    first_test: NDArray[np.bool_] | None = None,
) -> tuple[int, int]:
    """Remove intersecting faces in up to ``max_rounds + 1`` rounds.

    Each round tests, removes the faces found, repairs what that makes
    non-manifold and, except in the last round or without ``close_holes``,
    closes the holes left. Returns the faces the first test found and those
    the last test found: when the last round removed faces, the mesh is
    tested once more, so the second number is always the count on the
    mesh as it is left. Each test gives what :func:`count_intersecting_faces`
    gives on the mesh as it then is (rebuilt first), so callers need not
    count before or after. ``first_test``, the flags of that test on the mesh
    as it is now, saves the first one.

    After the first round only faces that can meet a face the round changed
    are tested again (:func:`_retest`), which gives the same flags.
    """
    found = last = 0
    cleared: set[bytes] | None = None  # faces the last test found meeting nothing
    for round_index in range(max_rounds + 2):
        vertices, faces = refresh(meshes, name)
        is_selected = first_test if round_index == 0 else None
        if is_selected is None and cleared is not None:
            is_selected = _retest(vertices, faces, cleared)
        if is_selected is None:
            run_filter(meshes, name, step, "compute_selection_by_self_intersections_per_face")
            is_selected = np.array(meshes.current_mesh().face_selection_array(), dtype=bool)
        else:
            select_faces(meshes, is_selected)
        selected = int(is_selected.sum())
        if round_index == 0:
            found = selected
        if selected == 0 or round_index > max_rounds:
            last = selected  # the count after the last round
            break
        cleared = _face_keys(vertices, faces[~is_selected])
        run_filter(meshes, name, step, "meshing_remove_selected_faces")
        repair_non_manifold(meshes, name, step)
        if round_index == max_rounds or not close_holes:
            continue  # the last round (or every round without close_holes) only removes
        try:
            meshes.apply_filter(
                "meshing_close_holes",
                maxholesize=HOLE_EDGES,
                selected=False,
                newfaceselected=False,
                selfintersection=True,
                refinehole=False,
            )
        except ml.PyMeshLabException:
            pass  # hole filling needs a manifold border; leave such holes open
        repair_non_manifold(meshes, name, step)
    run_filter(meshes, name, step, "set_selection_none")
    return found, last


_RETEST_MARGIN = 1e-6
"""Growth of the bounding boxes compared by :func:`_retest`, in units of the largest coordinate."""


_RETEST_CHANGED = 0.02
"""Above this fraction of changed faces :func:`_retest` tests everything: it is as fast then."""


def _corner_bytes(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> list[bytes]:
    """The bytes of each face's three corners in order."""
    corners = np.ascontiguousarray(vertices[faces], dtype=np.float64).reshape(len(faces), 9)
    # the items of an unstructured void array list as bytes
    return cast("list[bytes]", corners.view(np.dtype((np.void, 72))).ravel().tolist())


def _face_keys(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> set[bytes] | None:
    """Each face as the bytes of its three corners in order; None if two vertices coincide."""
    if len(np.unique(vertices, axis=0)) != len(vertices):
        return None
    return set(_corner_bytes(vertices, faces))


def _retest(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], cleared: set[bytes]
) -> NDArray[np.bool_] | None:
    """The self-intersection flags of the whole mesh, testing only near the faces that changed.

    pymeshlab's test flags a face if it meets another face with which it
    shares no vertex (or meets it improperly where they share some); it
    depends only on the two faces' corners and on which vertices they share.
    ``cleared`` holds the faces the previous test found meeting nothing
    (:func:`_face_keys`). Two such faces with the same corners, in the same
    order, still meet each other nowhere: where vertices are all at distinct
    positions (in both meshes), equal corners are the same vertices. So only
    pairs with a changed face (one not in ``cleared``) can meet, and both
    faces of such a pair have overlapping bounding boxes; the test runs on
    the changed faces and every face near them
    (:func:`~vptoolkit.clean.topology.faces_near`) and its flags are the whole
    mesh's. Returns None (test everything) if two vertices coincide, or many
    faces changed, or the neighbourhood is large.
    """
    if len(faces) == 0:
        return np.zeros(0, dtype=bool)
    if len(np.unique(vertices, axis=0)) != len(vertices):
        return None
    is_changed = np.fromiter((key not in cleared for key in _corner_bytes(vertices, faces)),
                             dtype=bool, count=len(faces))
    if not is_changed.any():
        return np.zeros(len(faces), dtype=bool)
    if is_changed.sum() > _RETEST_CHANGED * len(faces):
        return None
    margin = _RETEST_MARGIN * max(float(np.abs(vertices).max()), 1e-300)
    near = faces_near(vertices, faces, is_changed, margin)
    if near is None or near.sum() > len(faces) // 2:
        return None
    part = faces[near]
    used = np.unique(part)
    remap = np.zeros(len(vertices), dtype=np.int64)
    remap[used] = np.arange(len(used), dtype=np.int64)
    is_selected = np.zeros(len(faces), dtype=bool)
    is_selected[near] = intersecting_faces_of(vertices[used], remap[part])
    return is_selected
