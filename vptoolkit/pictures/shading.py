"""What both picture engines share: the style, the camera, the light and the colours.

:class:`vptoolkit.pictures.open3d_engine.Renderer` (Open3D, in a child process) and
:class:`vptoolkit.pictures.software_engine.SoftwareRenderer` (numpy over the
measures' rasteriser) draw the same pictures because they take these from one place:

* :func:`engine_setup`: an engine's checked picture size, camera and style;
* :class:`RenderStyle`: colours, crease angle, sun and image up;
* :func:`crease_normals`: unshared face corners with crease-aware normals
  (:class:`CreaseNormals`);
* :func:`picture_camera`: the measures' camera rolled to the style's up;
* :func:`light_direction`: where the sun shines from, relative to the camera;
* :func:`frame_zoom`: how much a view is magnified so the model fills the
  picture up to the style's margin;
* :func:`corner_colors` and :func:`texture_lookup`: a model's own colours
  (an :class:`~vptoolkit.appearance.Appearance`) in linear RGB;
* :func:`srgb_to_linear`, :func:`srgb8_to_linear` and :func:`linear_to_srgb`:
  the sRGB transfer curve.

Numpy only; neither engine is imported here.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from vptoolkit.appearance import Appearance
from vptoolkit.camera import Camera, ViewPoses
from vptoolkit.checks import check_int
from vptoolkit.errors import InputError
from vptoolkit.mesh import MeshLike, as_mesh
from vptoolkit.point_cloud import PointCloud

__all__ = [
    "PICTURE_SIZE",
    "MIN_PICTURE_SIZE",
    "MAX_PICTURE_SIZE",
    "RenderStyle",
    "engine_setup",
    "CreaseNormals",
    "crease_normals",
    "picture_camera",
    "light_direction",
    "frame_zoom",
    "corner_colors",
    "texture_lookup",
    "srgb_to_linear",
    "srgb8_to_linear",
    "linear_to_srgb",
]

PICTURE_SIZE = 512
"""Side of a picture in pixels unless one is given."""

MIN_PICTURE_SIZE = 16
"""Smallest picture side in pixels."""

MAX_PICTURE_SIZE = 4096
"""Largest picture side in pixels."""

MARGIN = 0.05
"""Free border around the framed model, as a fraction of the picture's side."""


@dataclass(frozen=True)
class RenderStyle:
    """How a picture is shaded (the camera itself is :class:`~vptoolkit.camera.Camera`).

    Parameters
    ----------
    color : tuple of 3 floats
        Surface colour, sRGB in [0, 1] (default: a light blue-grey).
    background : tuple of 3 floats
        Background colour, sRGB in [0, 1] (default: white).
    crease_angle_deg : float
        Normals are averaged over faces meeting at less than this angle and
        kept apart across sharper edges, in degrees (default: 40; 0 gives
        flat shading).
    light_elevation_deg, light_azimuth_deg : float
        Where the sun stands, seen from the camera: degrees above the view
        axis towards the image up, then around it towards the image left
        (defaults: 35 and 30).
    light_intensity : float
        Sun intensity in Filament's lux (default: 150000).
    ambient_intensity : float
        Intensity of Open3D's image-based ambient light (default: 20000).
    up : tuple of 3 floats
        Model direction shown as up in the picture (default: ``(0, 1, 0)``;
        where the view looks along it, the camera's fallback up, or the
        measures' ``-y``, serves instead).
    margin : float or None
        Framing: each picture is magnified about its centre (the eye stays
        where the measures put it, so the same faces are seen) until the
        model's projected bounding box touches a border this fraction of
        the picture's side wide, in [0, 0.45] (default: :data:`MARGIN`,
        0.05). None keeps the measures' framing, whose bounding sphere fits
        the circle inscribed in the picture (:func:`frame_zoom`).
    """

    color: tuple[float, float, float] = (0.72, 0.76, 0.82)
    background: tuple[float, float, float] = (1.0, 1.0, 1.0)
    crease_angle_deg: float = 40.0
    light_elevation_deg: float = 35.0
    light_azimuth_deg: float = 30.0
    light_intensity: float = 150000.0
    ambient_intensity: float = 20000.0
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    margin: float | None = MARGIN

    def __post_init__(self) -> None:
        for name in ("color", "background"):
            value = np.asarray(getattr(self, name), dtype=np.float64)
            if value.shape != (3,) or not np.isfinite(value).all() or (value < 0).any() or (
                value > 1
            ).any():
                raise InputError(
                    f"{name}: expected three values in [0, 1], got {getattr(self, name)}"
                )
            object.__setattr__(self, name, tuple(float(c) for c in value))
        if not 0.0 <= self.crease_angle_deg <= 180.0:
            raise InputError(f"crease_angle_deg: must lie in [0, 180], got {self.crease_angle_deg}")
        up = np.asarray(self.up, dtype=np.float64)
        if up.shape != (3,) or not np.isfinite(up).all() or not np.linalg.norm(up) > 0:
            raise InputError(f"up: expected a non-zero direction x, y, z, got {self.up}")
        object.__setattr__(self, "up", tuple(float(c) for c in up / np.linalg.norm(up)))
        for name in ("light_intensity", "ambient_intensity"):
            if not getattr(self, name) >= 0.0:
                raise InputError(f"{name}: must be >= 0, got {getattr(self, name)}")
        if self.margin is not None:
            if not 0.0 <= self.margin <= 0.45:
                raise InputError(f"margin: must lie in [0, 0.45] of the picture's side, "
                                 f"got {self.margin}")
            object.__setattr__(self, "margin", float(self.margin))

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe record of the style."""
        return asdict(self)


def engine_setup(size: int, camera: Camera | None,
                 style: RenderStyle | None) -> tuple[int, Camera, RenderStyle]:
    """The picture size, camera and style every engine starts from.

    Parameters
    ----------
    size : int
        Side of the square pictures in pixels, :data:`MIN_PICTURE_SIZE` to
        :data:`MAX_PICTURE_SIZE` (16 to 4096).
    camera : Camera or None
        Camera conventions; None gives ``Camera()``, those of the measures.
    style : RenderStyle or None
        Shading and image up; None gives ``RenderStyle()``.

    Returns
    -------
    size, camera, style : int, Camera, RenderStyle

    Raises
    ------
    InputError
        If ``size`` is not a whole number in range.
    """
    size = check_int(size, "size", minimum=MIN_PICTURE_SIZE, maximum=MAX_PICTURE_SIZE)
    return size, camera or Camera(), style or RenderStyle()


class CreaseNormals(NamedTuple):
    """Unshared face corners with crease-aware normals (see :func:`crease_normals`).

    Attributes
    ----------
    positions : (3 * n_kept, 3) float32
        The corners of every kept face (degenerate faces are dropped), face by face.
    normals : (3 * n_kept, 3) float32
        Unit normal per corner: the area-weighted mean of the normals of the
        faces at that vertex whose normal is within the crease angle of the
        corner's own face.
    face_points : (n_kept, 3) float64
        The first corner of each kept face (for back-face tests).
    face_normals : (n_kept, 3) float64
        Unit normal of each kept face.
    kept : (n_kept,) int64
        Index of each kept face in ``mesh.faces``.
    """

    positions: NDArray[np.float32]
    normals: NDArray[np.float32]
    face_points: NDArray[np.float64]
    face_normals: NDArray[np.float64]
    kept: NDArray[np.int64]


def crease_normals(mesh: MeshLike, crease_angle_deg: float) -> CreaseNormals:
    """Unshared corner positions and normals, smoothed within ``crease_angle_deg``.

    Normals are averaged over faces meeting at less than the crease angle (in
    degrees; 0 gives flat shading) and kept apart across sharper edges. Returns
    a :class:`CreaseNormals`.
    """
    mesh = as_mesh(mesh)
    corners = mesh.vertices[mesh.faces]  # (n_faces, 3, 3)
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    scale = max(float(np.abs(corners).max()), 1e-300)
    kept = double_area > 1e-14 * scale * scale
    faces = mesh.faces[kept]
    cross = cross[kept]
    unit = cross / double_area[kept][:, None]
    n_kept = len(faces)
    corner_vertex = faces.reshape(-1)  # (3 n_kept,)
    corner_face = np.repeat(np.arange(n_kept), 3)
    normals = np.repeat(unit, 3, axis=0)
    if crease_angle_deg > 0.0 and n_kept:
        order = np.argsort(corner_vertex, kind="stable")
        sorted_vertex = corner_vertex[order]
        starts = np.flatnonzero(np.r_[True, sorted_vertex[1:] != sorted_vertex[:-1]])
        sizes = np.diff(np.r_[starts, len(order)])
        size_of_corner = np.repeat(sizes, sizes)  # group size, per sorted corner
        start_of_corner = np.repeat(starts, sizes)
        if int((sizes.astype(np.int64) ** 2).sum()) <= 50_000_000:
            total = int(size_of_corner.sum())
            first = np.repeat(np.arange(len(order)), size_of_corner)  # sorted position of a
            offset = np.arange(total) - np.repeat(np.cumsum(size_of_corner) - size_of_corner,
                                                  size_of_corner)
            second = np.repeat(start_of_corner, size_of_corner) + offset  # sorted position of b
            face_a = corner_face[order[first]]
            face_b = corner_face[order[second]]
            cosine = np.einsum("ij,ij->i", unit[face_a], unit[face_b])
            keep = cosine >= math.cos(math.radians(crease_angle_deg)) - 1e-9
            target = order[first[keep]]
            weights = cross[face_b[keep]]  # area-weighted
            summed = np.zeros((3 * n_kept, 3))
            for axis in range(3):
                summed[:, axis] = np.bincount(target, weights=weights[:, axis],
                                              minlength=3 * n_kept)
            length = np.linalg.norm(summed, axis=1, keepdims=True)
            normals = np.where(length > 0, summed / np.where(length > 0, length, 1.0), normals)
    positions = mesh.vertices[faces].reshape(-1, 3)
    return CreaseNormals(
        positions.astype(np.float32),
        normals.astype(np.float32),
        mesh.vertices[faces[:, 0]],
        unit,
        np.flatnonzero(kept),
    )


def picture_camera(camera: Camera, up: tuple[float, float, float]) -> Camera:
    """The measures' camera rolled so that ``up`` is the image up."""
    fallback = camera.fallback_up
    if abs(float(np.dot(up, np.asarray(fallback) / np.linalg.norm(fallback)))) > 0.99:
        fallback = camera.up  # e.g. up = +z: fall back to the measures' own up
    return replace(camera, up=up, fallback_up=fallback)


def light_direction(style: RenderStyle, forward: NDArray[np.float64], up: NDArray[np.float64],
                    right: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit direction the sunlight travels in: from ``light_elevation_deg`` above the
    view axis towards the image up, turned ``light_azimuth_deg`` towards the image left."""
    elevation = math.radians(style.light_elevation_deg)
    azimuth = math.radians(style.light_azimuth_deg)
    towards_light = (
        -forward * math.cos(elevation) * math.cos(azimuth)
        + up * math.sin(elevation)
        - right * math.cos(elevation) * math.sin(azimuth)
    )
    return -towards_light / np.linalg.norm(towards_light)


def frame_zoom(poses: ViewPoses, points: NDArray[np.float64],
               margin: float | None) -> NDArray[np.float64]:
    """Magnification of each view that makes the model fill the picture up to ``margin``.

    With ``(x, y)`` the pixel coordinates of the points in view ``i``
    (:meth:`~vptoolkit.camera.ViewPoses.project`, side ``R`` = ``poses.resolution``)
    and ``m_i = max |x - R/2|, |y - R/2|`` over the points, the zoom is
    ``z_i = (1/2 - margin) R / m_i``: magnifying the picture by ``z_i``
    about its centre (focal length ``z_i f``, the eye unchanged) puts the
    farthest projected point on the inner edge of a border ``margin R``
    wide, so the projected bounding box touches it on at least one side
    and crosses it on none, whatever the model's shape.

    Parameters
    ----------
    poses : ViewPoses
        The measures' poses of the views.
    points : (n, 3) float64
        The model's points (the vertices its faces use), in front of every eye.
    margin : float or None
        Border width as a fraction of the side; None gives zoom 1 for every
        view (the measures' framing).

    Returns
    -------
    zoom : (n_views,) float64
        Positive factors; 1 where ``margin`` is None or the points project
        to the centre.
    """
    n_views = len(poses.eyes)
    if margin is None or len(points) == 0:
        return np.ones(n_views)
    half = poses.resolution / 2.0
    zoom = np.ones(n_views)
    for view in range(n_views):
        pixels = poses.project(view, points)[:, :2]
        reach = float(np.abs(pixels - half).max())
        if reach > 0.0:
            zoom[view] = (0.5 - margin) * poses.resolution / reach
    return zoom


def picture_poses(camera: Camera, style: RenderStyle, model: MeshLike | PointCloud,
                  directions: NDArray[np.float64], resolution: int
                  ) -> tuple[ViewPoses, NDArray[np.float64]]:
    """The cameras of a model's pictures: poses and the magnification of each view.

    Parameters
    ----------
    camera : Camera
        The measures' camera (an engine's ``camera``).
    style : RenderStyle
        Its ``up`` rolls the camera (:func:`picture_camera`), its ``margin``
        frames the model (:func:`frame_zoom`).
    model : MeshLike or PointCloud
        The model: its bounding frame (:func:`vptoolkit.geometry.bounding_frame`)
        places the camera, its used vertices (a cloud: its points) decide the zoom.
    directions : (n, 3) float64
        Unit view directions, model centre towards the camera.
    resolution : int
        Image side of the poses in pixels.

    Returns
    -------
    poses : ViewPoses
        The rolled camera's poses at ``resolution``, before magnification.
    zoom : (n,) float64
        Each view's magnification: the picture of view ``i`` has focal length
        ``zoom[i] * poses.focal_px`` pixels at ``resolution``, the eye unchanged.
    """
    from vptoolkit.geometry import bounding_frame

    if isinstance(model, PointCloud):
        points = model.points
    else:
        mesh = as_mesh(model)
        points = mesh.vertices[np.unique(mesh.faces)]
    centre, diagonal = bounding_frame(model)
    poses = picture_camera(camera, style.up).poses(directions, centre=centre,
                                                   diagonal=diagonal, resolution=resolution)
    return poses, frame_zoom(poses, points, style.margin)


def corner_colors(appearance: Appearance | None, faces: NDArray[np.int64],
                  n_vertices: int) -> NDArray[np.float64] | None:
    """Linear RGB per face corner from a model's colours (its texture aside).

    The colour of a corner is the product of what the appearance holds of:
    its vertex's colour, its face's colour and the base colour (glTF
    multiplies ``COLOR_0`` by ``baseColorFactor``; an OBJ material gives a
    face colour or the base colour). Alpha is ignored: every surface is drawn
    opaque.

    Parameters
    ----------
    appearance : Appearance or None
        The model's appearance, indexed like its vertices and faces.
    faces : (n_faces, 3) int
        The mesh's triangles.
    n_vertices : int
        The mesh's vertex count (to check the appearance belongs to it).

    Returns
    -------
    colors : (n_faces, 3, 3) float64 or None
        Linear RGB in [0, 1]; None when the appearance has no colour and no
        texture with texture coordinates (then the style's colour applies);
        1 at every corner where it has only a texture (its multiplier).

    Raises
    ------
    InputError
        If the appearance's arrays do not match the mesh's counts.
    """
    if appearance is None or (
            appearance.vertex_colors is None and appearance.face_colors is None
            and appearance.base_color is None
            and (appearance.texture is None or appearance.corner_uv is None)):
        return None
    colors = np.ones((len(faces), 3, 3))
    if appearance.vertex_colors is not None:
        if len(appearance.vertex_colors) != n_vertices:
            raise InputError(f"appearance: {len(appearance.vertex_colors)} vertex colours for "
                             f"{n_vertices} vertices")
        colors *= srgb8_to_linear(appearance.vertex_colors[:, :3])[faces]
    for name in ("face_colors", "corner_uv"):
        array = getattr(appearance, name)
        if array is not None and len(array) != len(faces):
            raise InputError(f"appearance: {name} has {len(array)} rows for {len(faces)} faces")
    if appearance.face_colors is not None:
        colors *= srgb8_to_linear(appearance.face_colors[:, :3])[:, None, :]
    if appearance.base_color is not None:
        colors *= np.clip(appearance.base_color[:3], 0.0, 1.0)
    return colors


def texture_lookup(texture: NDArray[np.float32], uv: NDArray[np.float64], *,
                   bilinear: bool = True) -> NDArray[np.float64]:
    """Colours of a texture at texture coordinates, repeating outside [0, 1].

    Parameters
    ----------
    texture : (height, width, 3) float32
        The image in linear RGB (:func:`srgb8_to_linear` of the stored
        sRGB), its first row the top (``v = 1``).
    uv : (n, 2) float64
        Finite ``(u, v)`` with ``(0, 0)`` the bottom-left corner of the image and
        ``(1, 1)`` its top-right (glTF's ``REPEAT`` wrapping outside).
    bilinear : bool
        Blend the four texels around each point, weighted by distance, in
        linear RGB (default); False takes the nearest texel.

    Returns
    -------
    colors : (n, 3) float64
        Linear RGB; texel ``(i, j)``'s centre is at ``u = (j + 1/2) / width``,
        ``v = 1 - (i + 1/2) / height``.
    """
    height, width = texture.shape[:2]
    x = np.mod(uv[:, 0], 1.0) * width - 0.5
    y = (1.0 - np.mod(uv[:, 1], 1.0)) * height - 0.5
    if not bilinear:
        column = np.mod(np.round(x).astype(np.int64), width)
        row = np.mod(np.round(y).astype(np.int64), height)
        return texture[row, column].astype(np.float64)
    left, top = np.floor(x), np.floor(y)
    dx, dy = (x - left)[:, None], (y - top)[:, None]
    # left in [-1, width - 1] and top in [-1, height - 1] (x, y >= -1/2 and below the
    # side): the neighbours wrap by one comparison each, not an integer division
    c0 = left.astype(np.int64)
    c0[c0 < 0] += width
    c1 = c0 + 1
    c1[c1 == width] = 0
    row = top.astype(np.int64)
    row[row < 0] += height
    below = row + 1
    below[below == height] = 0
    r0, r1 = row * width, below * width  # flat row starts: np.take on the flat
    # image is several times faster than texture[row, column]
    texels = texture.reshape(height * width, -1)

    def texel(start: NDArray[np.int64], column: NDArray[np.int64]) -> NDArray[np.float32]:
        return np.take(texels, start + column, axis=0)

    return ((1 - dy) * ((1 - dx) * texel(r0, c0) + dx * texel(r0, c1))
            + dy * ((1 - dx) * texel(r1, c0) + dx * texel(r1, c1)))


def srgb_to_linear(value: float) -> float:
    """One sRGB channel value in [0, 1] to linear RGB."""
    return value / 12.92 if value <= 0.04045 else ((value + 0.055) / 1.055) ** 2.4


def srgb8_to_linear(values: NDArray[np.uint8]) -> NDArray[np.float32]:
    """8-bit sRGB values (any shape) to linear RGB in [0, 1], as :func:`srgb_to_linear`."""
    return _SRGB8_TO_LINEAR[np.asarray(values, dtype=np.uint8)]


_SRGB8_TO_LINEAR = np.array([srgb_to_linear(level / 255.0) for level in range(256)],
                            dtype=np.float32)


def linear_to_srgb(linear: NDArray[np.float64]) -> NDArray[np.uint8]:
    """Linear RGB in [0, 1] (clipped) to 8-bit sRGB."""
    value = np.clip(linear, 0.0, 1.0)
    srgb = np.where(value <= 0.0031308, 12.92 * value, 1.055 * np.power(value, 1.0 / 2.4) - 0.055)
    return np.clip(np.round(srgb * 255.0), 0, 255).astype(np.uint8)
