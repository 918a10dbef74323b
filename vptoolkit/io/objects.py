"""Other libraries' models turned into a Mesh or a PointCloud, recognised by their attributes.

Neither trimesh nor Open3D is imported to recognise an object (a caller who
has one has imported its library already); the rules, in order:

* a :class:`~vptoolkit.mesh.Mesh` or :class:`~vptoolkit.point_cloud.PointCloud`
  is returned as it is;
* a numpy array (or anything ``np.ndim`` sees as 2-D) of shape ``(N, 3)``
  or ``(N, 6)`` is points, then normals;
* a tuple ``(vertices, faces)`` is a mesh (:func:`vptoolkit.mesh.as_mesh`);
* an object with ``graph`` and ``geometry`` (``trimesh.Scene``) is
  flattened with its node transforms, as a glTF file is
  (:func:`vptoolkit.io.gltf.read_scene`): a mesh, or a point cloud when it
  holds points and no triangles;
* ``vertices`` and ``faces`` (``trimesh.Trimesh``) or ``vertices`` and
  ``triangles`` (Open3D ``TriangleMesh``): a mesh;
* ``points`` and ``has_normals`` (Open3D ``PointCloud``): points, with
  normals when it has them;
* ``vertices`` alone (``trimesh.PointCloud``): points.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vptoolkit.errors import InputError
from vptoolkit.mesh import Mesh, as_mesh
from vptoolkit.point_cloud import PointCloud

__all__ = ["model_of"]


def model_of(source: Any, name: str | None = None) -> Mesh | PointCloud:
    """The :class:`Mesh` or :class:`PointCloud` of another library's object (module docstring).

    Parameters
    ----------
    source : object
        The model.
    name : str, optional
        The converted model's name (default: "mesh" or "points"); a Mesh or
        PointCloud keeps its own.

    Returns
    -------
    Mesh or PointCloud

    Raises
    ------
    InputError
        ``model: expected a Mesh, a PointCloud, a trimesh or Open3D mesh,
        point cloud or scene, an (N, 3) array or (vertices, faces), got dict``
        for anything else (a path is :func:`vptoolkit.io.load`'s), or the
        container's check of the arrays.
    """
    if isinstance(source, (Mesh, PointCloud)):
        return source
    mesh_name, points_name = name or "mesh", name or "points"
    if isinstance(source, tuple) and len(source) == 2:
        return as_mesh(source, mesh_name)
    if isinstance(source, (np.ndarray, list)):
        try:
            table = np.asarray(source, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(f"{points_name}: expected an (N, 3) or (N, 6) point array, got a "
                             f"{type(source).__qualname__} that is not one") from None
        if table.ndim != 2 or table.shape[1] not in (3, 6):
            raise InputError(f"{points_name}: expected an (N, 3) or (N, 6) point array, "
                             f"got shape {table.shape}")
        return PointCloud(table[:, :3], table[:, 3:] if table.shape[1] == 6 else None,
                          name=points_name)
    if hasattr(source, "graph") and hasattr(source, "geometry"):
        return _scene_model(source, mesh_name)
    if hasattr(source, "vertices") and (hasattr(source, "faces") or hasattr(source, "triangles")):
        return as_mesh(source, mesh_name)
    if hasattr(source, "points") and hasattr(source, "has_normals"):
        normals = np.asarray(source.normals) if source.has_normals() else None
        return PointCloud(np.asarray(source.points), normals, name=points_name)
    if hasattr(source, "vertices"):
        return PointCloud(np.asarray(source.vertices), name=points_name)
    raise InputError("model: expected a Mesh, a PointCloud, a trimesh or Open3D mesh, "
                     "point cloud or scene, an (N, 3) array or (vertices, faces), "
                     f"got {type(source).__qualname__}")


def _scene_model(scene: Any, name: str) -> Mesh | PointCloud:
    """A trimesh scene flattened as a glTF file is."""
    from vptoolkit.io._polygons import FormatError, check_and_triangulate
    from vptoolkit.io.gltf import read_scene

    reading = read_scene(scene, name)
    if len(reading.polygons[1]) == 0:
        if not len(reading.vertices):
            raise InputError(f"{name}: the scene holds no triangles and no points")
        return PointCloud(reading.vertices, name=name)
    try:
        faces = check_and_triangulate(reading.vertices, reading.polygons)
    except FormatError as err:
        raise InputError(f"{name}: {err}") from err
    return Mesh(reading.vertices, faces, name=name)
