"""Step 3 of :mod:`vptoolkit.clean`: decimate to a face budget, optionally remesh.

Owns :func:`simplify_mesh` and its result :class:`SimplifiedMesh`,
:data:`MAX_FACES` and the quadric edge-collapse passes
(:func:`simplify_meshset`, on a pymeshlab MeshSet), followed by the removal of
the intersections decimation created.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Any

from vptoolkit.checks import check_bool, check_int
from vptoolkit.clean._meshlab import (
    face_count,
    load_pymeshlab,
    repair_non_manifold,
    run_filter,
    to_arrays,
    to_mesh,
    to_meshset,
)
from vptoolkit.clean.repair import remove_intersections
from vptoolkit.errors import MeasurementError
from vptoolkit.geometry import face_areas
from vptoolkit.mesh import Mesh, MeshLike, as_mesh

if TYPE_CHECKING:
    import pymeshlab

MAX_FACES = 10_000
"""Default face budget after cleaning (the paper uses models with at most 10k faces)."""

_AFTER_DECIMATION_ROUNDS = 3
"""Rounds of removing the faces that decimation left intersecting (see :func:`simplify_mesh`)."""


@dataclass(frozen=True, eq=False, repr=False, kw_only=True)
class SimplifiedMesh(Mesh):
    """The mesh :func:`simplify_mesh` returns: a :class:`~vptoolkit.mesh.Mesh`, intersections left.

    Attributes
    ----------
    intersections_after : int
        Faces pymeshlab's self-intersection test still selects, normally 0.
    """

    intersections_after: int


def simplify_mesh(mesh: MeshLike, *, max_faces: int = MAX_FACES,
                  remesh: bool = False) -> SimplifiedMesh:
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
    parts close together (wings, seams left by step 1) it can create some
    (2.3 % of a raw ModelNet airplane's faces). The faces that intersect are
    removed afterwards, in up to three rounds, without closing the holes,
    which would also fill the model's own openings and add faces.

    With ``remesh=True`` an isotropic explicit remeshing (10 iterations,
    creases above 30 degrees kept, vertices reprojected onto the surface)
    then evens out the triangles, aiming at about 80% of ``max_faces``;
    decimation runs again if it overshoots.

    Parameters
    ----------
    mesh : MeshLike
        The mesh to simplify.
    max_faces : int
        Face budget, at least 4 (default: 10000).
    remesh : bool
        Also remesh isotropically (default: False).

    Returns
    -------
    simplified : SimplifiedMesh
        At most ``max_faces`` faces, and the intersections left.

    Raises
    ------
    MeasurementError
        If the budget cannot be met or a filter fails; the message starts with
        the mesh name.
    """
    mesh = as_mesh(mesh)
    max_faces = check_int(max_faces, "max_faces", minimum=4)
    remesh = check_bool(remesh, "remesh")
    ml = load_pymeshlab()
    meshes = to_meshset(ml, mesh.vertices, mesh.faces, mesh.name)
    simplify_meshset(ml, meshes, mesh.name, max_faces, remesh)
    _, intersections_after = remove_intersections(
        ml, meshes, mesh.name, _AFTER_DECIMATION_ROUNDS - 1, step="simplify", close_holes=False
    )
    simplified = to_mesh(meshes, mesh.name, "simplify")
    return SimplifiedMesh(simplified.vertices, simplified.faces, simplified.name,
                          intersections_after=intersections_after)


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


def simplify_meshset(
    ml: ModuleType, meshes: pymeshlab.MeshSet, name: str, max_faces: int, remesh: bool
) -> None:
    _decimate(meshes, name, max_faces)
    if remesh:
        vertices, faces, _ = to_arrays(meshes)
        area = float(face_areas(Mesh(vertices, faces, name=name)).sum())
        # An equilateral triangle of side L has area sqrt(3)/4 L^2.
        target_length = math.sqrt(4.0 * area / (math.sqrt(3.0) * 0.8 * max_faces))
        run_filter(
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
        repair_non_manifold(meshes, name, "simplify")
        _decimate(meshes, name, max_faces)
    if face_count(meshes) > max_faces:
        raise MeasurementError(
            f"{name}: simplify: decimation stopped at {face_count(meshes)} faces, "
            f"above max_faces={max_faces}"
        )


def _decimate(meshes: pymeshlab.MeshSet, name: str, max_faces: int) -> None:
    for params in _DECIMATION_PASSES:
        if face_count(meshes) <= max_faces:
            return
        run_filter(
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
        repair_non_manifold(meshes, name, "simplify")
