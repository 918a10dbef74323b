"""The private pymeshlab bridge of :mod:`vptoolkit.clean`.

Owns everything that touches pymeshlab directly: importing it lazily and
settling its process-wide face flag state (:func:`load_pymeshlab`), building a
pymeshlab mesh from arrays (:func:`pymeshlab_mesh`, :func:`to_meshset`) and
reading one back (:func:`to_arrays`, :func:`to_mesh`), applying a filter with
the toolkit's error message (:func:`run_filter`), pymeshlab's self-intersection
test (:func:`intersecting_faces`, :func:`count_intersecting_faces`) and the
null, duplicate and non-manifold repairs that every step runs after editing a
mesh (:func:`repair_non_manifold`). Nothing here is public API.
"""

from __future__ import annotations

from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import one_line
from vptoolkit.errors import MeasurementError
from vptoolkit.mesh import Mesh
from vptoolkit.optional import require

if TYPE_CHECKING:
    import pymeshlab

HOLE_EDGES = 30
"""Largest hole, in border edges, that the ``"remove"`` method closes."""

_SPLIT_DISPLACEMENT = 0.01
"""How far a split non-manifold vertex moves towards its faces, as a fraction of their size.

Coincident copies would leave faces touching at a point without sharing a
vertex, which pymeshlab's self-intersection test reports unreliably.
"""


def load_pymeshlab() -> ModuleType:
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
            meshes.apply_filter("meshing_close_holes", maxholesize=HOLE_EDGES)
        except ml.PyMeshLabException:  # pragma: no cover - a pymeshlab without these filters
            return


def to_meshset(
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
    meshes.add_mesh(pymeshlab_mesh(ml, vertices, faces, origin), name)
    return meshes


def pymeshlab_mesh(
    ml: ModuleType,
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    origin: NDArray[np.int64],
) -> pymeshlab.Mesh:
    """A pymeshlab Mesh of the arrays; ``origin + 1`` rides along as face quality."""
    return ml.Mesh(
        vertex_matrix=np.ascontiguousarray(vertices, dtype=np.float64),
        face_matrix=np.ascontiguousarray(faces, dtype=np.int32),
        f_scalar_array=(origin + 1).astype(np.float64),
    )


def to_arrays(
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


def to_mesh(meshes: pymeshlab.MeshSet, name: str, step: str) -> Mesh:
    vertices, faces, _ = to_arrays(meshes)
    if len(faces) == 0:
        raise MeasurementError(f"{name}: cleaning step {step!r} left no faces")
    return Mesh(vertices, faces, name=name)


def run_filter(
    meshes: pymeshlab.MeshSet, name: str, step: str, filter_name: str, **params: Any
) -> None:
    ml = load_pymeshlab()
    try:
        meshes.apply_filter(filter_name, **params)
    except ml.PyMeshLabException as err:
        raise MeasurementError(
            f"{name}: {step}: pymeshlab {filter_name} failed: {one_line(err)}"
        ) from err


def face_count(meshes: pymeshlab.MeshSet) -> int:
    return int(meshes.current_mesh().face_number())


def refresh(
    meshes: pymeshlab.MeshSet, name: str
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Rebuild the current mesh from its arrays, keeping face origins; return vertices and faces.

    pymeshlab's self-intersection test can disagree with itself on a mesh
    edited by earlier filters (stale adjacency); a rebuilt mesh gives the same
    answer as a freshly loaded one.
    """
    ml = load_pymeshlab()
    vertices, faces, origin = to_arrays(meshes)
    meshes.clear()
    meshes.add_mesh(pymeshlab_mesh(ml, vertices, faces, origin), name)
    return vertices, faces


def select_faces(meshes: pymeshlab.MeshSet, is_selected: NDArray[np.bool_]) -> None:
    """Make exactly the flagged faces of the current mesh selected (vertex selection untouched)."""
    current = meshes.current_mesh()
    current.add_face_custom_scalar_attribute(is_selected.astype(np.float64), _SELECTION_ATTRIBUTE)
    meshes.apply_filter(
        "compute_selection_by_condition_per_face", condselect=f"{_SELECTION_ATTRIBUTE} > 0"
    )


_SELECTION_ATTRIBUTE = "vptoolkit_selected"


def intersecting_faces_of(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> NDArray[np.bool_]:
    """Per-face flag of pymeshlab's self-intersection test on a mesh built from the arrays."""
    ml = load_pymeshlab()
    meshes = ml.MeshSet(verbose=False)
    if len(faces) == 0:
        return np.zeros(0, dtype=bool)
    meshes.add_mesh(
        ml.Mesh(
            vertex_matrix=np.ascontiguousarray(vertices, dtype=np.float64),
            face_matrix=np.ascontiguousarray(faces, dtype=np.int32),
        ),
        "part",
    )
    meshes.apply_filter("compute_selection_by_self_intersections_per_face")
    return np.array(meshes.current_mesh().face_selection_array(), dtype=bool)


def intersecting_faces(meshes: pymeshlab.MeshSet) -> NDArray[np.bool_]:
    """Per-face flag of pymeshlab's self-intersection test (rebuilds the mesh first)."""
    refresh(meshes, meshes.current_mesh().label())
    current = meshes.current_mesh()
    if current.face_number() == 0:
        return np.zeros(0, dtype=bool)
    meshes.apply_filter("compute_selection_by_self_intersections_per_face")
    selected = np.array(meshes.current_mesh().face_selection_array(), dtype=bool)
    meshes.apply_filter("set_selection_none")
    return selected


def count_intersecting_faces(meshes: pymeshlab.MeshSet) -> int:
    return int(intersecting_faces(meshes).sum())


def remove_null_and_duplicates(meshes: pymeshlab.MeshSet, name: str, step: str) -> None:
    run_filter(meshes, name, step, "meshing_remove_duplicate_faces")
    run_filter(meshes, name, step, "meshing_remove_null_faces")
    run_filter(meshes, name, step, "meshing_remove_unreferenced_vertices")


def repair_non_manifold(meshes: pymeshlab.MeshSet, name: str, step: str) -> None:
    """Null and duplicate faces, then non-manifold edges and vertices, until stable."""
    remove_null_and_duplicates(meshes, name, step)
    for _ in range(4):
        before = (face_count(meshes), int(meshes.current_mesh().vertex_number()))
        run_filter(meshes, name, step, "meshing_repair_non_manifold_edges", method="Remove Faces")
        run_filter(
            meshes,
            name,
            step,
            "meshing_repair_non_manifold_vertices",
            vertdispratio=_SPLIT_DISPLACEMENT,
        )
        remove_null_and_duplicates(meshes, name, step)
        if (face_count(meshes), int(meshes.current_mesh().vertex_number())) == before:
            break
    if face_count(meshes) == 0:
        raise MeasurementError(f"{name}: cleaning step {step!r} left no faces")
