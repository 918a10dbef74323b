"""Read glTF and GLB scenes through trimesh, flattened into one triangle list."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import one_line
from vptoolkit.errors import InputError
from vptoolkit.files import parse_json
from vptoolkit.io._polygons import FormatError, Polygons, triangle_polygons

__all__ = ["read_gltf"]


def read_gltf(path: Path, data: bytes) -> tuple[NDArray[np.float64], Polygons]:
    """Flatten a glTF (``.gltf``) or GLB (``.glb``) scene, applying every node transform.

    Mesh instances are concatenated in scene-graph order; a transform with a
    negative determinant reverses the triangles' winding to keep them facing out.
    Point and line primitives are ignored. trimesh is imported on first use.

    Parameters
    ----------
    path : Path
        The file, whose suffix names the format; trimesh reads it from here,
        together with any external buffers it refers to.
    data : bytes
        The file's content, checked before trimesh sees it.

    Returns
    -------
    vertices : (n_vertices, 3) float64
        The vertices of every mesh instance in world coordinates. A scene
        without triangle meshes gives one zero row per point or line vertex.
    polygons : Polygons
        The triangles, indexing into ``vertices``.

    Raises
    ------
    FormatError
        If a ``.gltf`` file is not JSON or a ``.glb`` file lacks the ``glTF``
        magic. trimesh's own exceptions propagate.
    """
    import trimesh  # lazy: only glTF needs it

    suffix = path.suffix.lower()
    if suffix == ".gltf":
        try:
            parse_json(data, path.name)
        except InputError as err:
            raise FormatError(f"invalid glTF JSON ({one_line(str(err.__cause__ or err))})") from err
    elif not data.startswith(b"glTF"):
        raise FormatError("not a GLB file (it does not start with 'glTF')")
    try:
        scene = trimesh.load_scene(str(path), file_type=suffix[1:], process=False)
    except AssertionError as err:  # trimesh asserts on buffers shorter than their views
        raise FormatError(
            "truncated or inconsistent glTF (a buffer is shorter than its views and "
            f"accessors declare{': ' + one_line(str(err)) if str(err) else ''})"
        ) from err
    vertex_blocks: list[NDArray[np.float64]] = []
    face_blocks: list[NDArray[np.int64]] = []
    n_vertices = n_other_points = 0
    for node in scene.graph.nodes_geometry:
        transform, geometry_name = scene.graph[node]
        geometry = scene.geometry[geometry_name]
        if not isinstance(geometry, trimesh.Trimesh):
            n_other_points += len(getattr(geometry, "vertices", ()))
            continue
        rotation, translation = transform[:3, :3], transform[:3, 3]
        points = np.asarray(geometry.vertices, dtype=np.float64).reshape(-1, 3)
        faces = np.asarray(geometry.faces, dtype=np.int64).reshape(-1, 3)
        if np.linalg.det(rotation) < 0:
            faces = faces[:, ::-1]
        vertex_blocks.append(points @ rotation.T + translation)
        face_blocks.append(faces + n_vertices)
        n_vertices += len(points)
    if not vertex_blocks:  # report points and lines as vertices without faces
        return np.zeros((n_other_points, 3)), triangle_polygons(np.zeros((0, 3), np.int64))
    return np.concatenate(vertex_blocks), triangle_polygons(np.concatenate(face_blocks))
