"""Read glTF and GLB scenes through trimesh, flattened into one triangle list with its look."""

from __future__ import annotations

import logging
from functools import partial
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import one_line
from vptoolkit.errors import InputError
from vptoolkit.files import parse_json
from vptoolkit.io._polygons import FormatError, Reading, triangle_polygons
from vptoolkit.io.images import image_rgba

_log = logging.getLogger(__name__)

__all__ = ["read_gltf", "read_scene"]


def read_gltf(path: Path, data: bytes) -> Reading:
    """Flatten a glTF (``.gltf``) or GLB (``.glb``) scene, applying every node transform.

    Mesh instances are concatenated in scene-graph order; a transform with a
    negative determinant reverses the triangles' winding to keep them facing out.
    Line primitives are ignored. trimesh is imported on first use.

    The appearance of each instance comes along: its material's base colour
    (``baseColorFactor``: one ``base_color`` when every instance has the
    same, else a colour per triangle), its vertex colours (kept when every
    instance has them), and its texture coordinates with the base-colour
    texture (the first instance's image; instances with another image or
    none get NaN coordinates, and a warning says so when an image is dropped).

    Parameters
    ----------
    path : Path
        The file, whose suffix names the format; trimesh reads it from here,
        together with any external buffers it refers to.
    data : bytes
        The file's content, checked before trimesh sees it.

    Returns
    -------
    Reading
        The vertices of every mesh instance in world coordinates and the
        triangles indexing into them, with the colours and texture
        coordinates above (``(0, 0)`` the bottom-left of the image, as trimesh
        flips glTF's top-left origin). A scene without triangle meshes gives
        its point primitives' vertices, in world coordinates, and no faces.

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
    return read_scene(scene, path.name)


def read_scene(scene: Any, label: str) -> Reading:
    """Flatten a ``trimesh.Scene`` as :func:`read_gltf` does; ``label`` names it in warnings."""
    import trimesh  # lazy: the scene is trimesh's

    parts: list[_Instance] = []
    points: list[NDArray[np.float64]] = []
    for node in scene.graph.nodes_geometry:
        transform, geometry_name = scene.graph[node]
        geometry = scene.geometry[geometry_name]
        rotation, translation = transform[:3, :3], transform[:3, 3]
        if not isinstance(geometry, trimesh.Trimesh):
            if isinstance(geometry, trimesh.PointCloud):
                vertices = np.asarray(geometry.vertices, dtype=np.float64).reshape(-1, 3)
                points.append(vertices @ rotation.T + translation)
            continue
        vertices = np.asarray(geometry.vertices, dtype=np.float64).reshape(-1, 3)
        faces = np.asarray(geometry.faces, dtype=np.int64).reshape(-1, 3)
        if np.linalg.det(rotation) < 0:
            faces = faces[:, ::-1]
        parts.append(_instance(geometry, vertices @ rotation.T + translation, faces))
    if not parts:  # a point cloud, or nothing (no vertices: the loader's message)
        cloud = np.concatenate(points) if points else np.zeros((0, 3))
        return Reading(cloud, triangle_polygons(np.zeros((0, 3), np.int64)))
    return _joined(parts, label)


class _Instance(NamedTuple):
    """One placed mesh of the scene and its look."""

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    color: NDArray[np.uint8]  # (4,) the material's base colour
    vertex_colors: NDArray[np.uint8] | None
    uv: NDArray[np.float64] | None
    image: Any  # a PIL image or None


def _instance(geometry: Any, vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> _Instance:
    """A mesh instance with its material's base colour, vertex colours, UVs and image."""
    visual = geometry.visual
    color = np.full(4, 255, dtype=np.uint8)
    vertex_colors = uv = image = None
    material = getattr(visual, "material", None)
    if material is not None:
        factor = getattr(material, "baseColorFactor", None)
        if factor is not None:
            color = np.asarray(factor, dtype=np.uint8).reshape(4)
        image = getattr(material, "baseColorTexture", None)
        if getattr(visual, "uv", None) is not None and len(visual.uv) == len(vertices):
            uv = np.asarray(visual.uv, dtype=np.float64)
    if getattr(visual, "kind", None) == "vertex":
        vertex_colors = np.asarray(visual.vertex_colors, dtype=np.uint8).reshape(-1, 4)
    return _Instance(vertices, faces, color, vertex_colors, uv, image)


def _joined(parts: list[_Instance], file_name: str) -> Reading:
    """The instances concatenated: one vertex list, triangles and their appearance."""
    offsets = np.cumsum([0] + [len(part.vertices) for part in parts])
    vertices = np.concatenate([part.vertices for part in parts])
    faces = np.concatenate([part.faces + offset for part, offset in zip(parts, offsets)])
    colors = np.array([part.color for part in parts])
    base_color = polygon_colors = vertex_colors = vertex_uv = texture = None
    if (colors == colors[0]).all():
        base_color = colors[0] / 255.0
    else:
        polygon_colors = np.repeat(colors, [len(part.faces) for part in parts], axis=0)
    if all(part.vertex_colors is not None for part in parts):
        vertex_colors = np.concatenate([part.vertex_colors for part in parts])
    image = next((part.image for part in parts if part.image is not None and part.uv is not None),
                 None)
    if image is not None:
        if any(part.image is not None and part.image is not image for part in parts):
            _log.warning("%s: several texture images; only the first is kept", file_name)
        vertex_uv = np.concatenate([
            part.uv if part.uv is not None and part.image is image
            else np.full((len(part.vertices), 2), np.nan) for part in parts])
        texture = partial(image_rgba, image)
    return Reading(vertices, triangle_polygons(faces), vertex_colors=vertex_colors,
                   polygon_colors=polygon_colors, vertex_uv=vertex_uv, base_color=base_color,
                   texture=texture)
