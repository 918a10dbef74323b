"""Shaded pictures from the measures' own triangle-ID rasteriser (no GPU, no Vulkan).

:class:`SoftwareRenderer` draws the same pictures as
:class:`vptoolkit.pictures.open3d_engine.Renderer` (same camera, roll and :class:`RenderStyle`)
without Open3D: :func:`vptoolkit.visibility.face_id_images` finds the face
seen through every pixel at ``supersampling`` times the picture's size, and
each pixel is shaded in numpy:

* its normal is the crease-aware corner normals of that face
  (:func:`vptoolkit.pictures.shading.crease_normals`) interpolated with the
  barycentric coordinates of the pixel ray's hit (Moller-Trumbore), turned
  towards the camera;
* its surface colour is the model's own where an
  :class:`~vptoolkit.appearance.Appearance` is given: the corner colours
  (:func:`vptoolkit.pictures.shading.corner_colors`: vertex, face and base
  colours) interpolated with the same barycentric coordinates, times the
  base-colour texture at the interpolated texture coordinates (bilinear,
  :func:`vptoolkit.pictures.shading.texture_lookup`), all in linear RGB;
  the style's colour otherwise;
* linear colour = ``colour * (ambient + sun * max(0, n . l))`` with the sun
  where ``RenderStyle`` puts it (above and to the left of the camera);
  ``ambient`` and ``sun`` come from the style's intensities relative to
  Open3D's defaults, so both engines brighten and darken together;
* framing (``RenderStyle.margin``): a view magnified ``z`` times
  (:func:`vptoolkit.pictures.shading.frame_zoom`) is rasterised at
  ``z`` times the side with the same field of view and its centre kept
  (the side rounded down to keep the parity, so the centre stays on a
  pixel corner), which is the magnified picture; ``z < 1`` pads instead.
  The rasterised side is at most 4096, so a model that needs more
  magnification than that allows (a needle seen end on, pictures of
  2048 px and more) fills less than the frame;
* the supersampled linear image is averaged down (anti-aliasing over the
  background) and encoded as sRGB.

A :class:`~vptoolkit.point_cloud.PointCloud` is drawn as the measures see
it: :meth:`vptoolkit.visibility.splats.PointScene.id_images` gives the point
whose splat is nearest at every pixel (each point a splat of twice the
radius of its own piece of surface, flattened along its normal, as the
measures' splats; the same culling), and the pixel takes that point's colour
(the :class:`~vptoolkit.appearance.Appearance`'s per-point colours times its
base colour, the style's colour without them), lit as above along the
point's normal, or, in a cloud without normals, as a surface across the
view axis (flat: ``n`` the view axis towards the eye, the same for every pixel).
Framing, supersampling and the sun are the mesh's.

Why a second engine: Open3D 0.20 renders through Vulkan, and on Mesa's
software driver (llvmpipe, the only one on a machine without a GPU) its
frame time depends on the view in ways we cannot control: 0.06 s for one
view of a mesh, minutes for another (measured with Open3D alone, see
``tools/bench_render.py``). This engine takes a fraction of a second for any
view and is the default of ``vptool render``, ``thumbnails`` and
``report``; ``--engine open3d`` keeps Filament's physically based shading.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.appearance import Appearance
from vptoolkit.camera import Camera, ViewPoses
from vptoolkit.checks import check_int
from vptoolkit.mesh import Mesh, MeshLike, as_mesh
from vptoolkit.pictures.shading import (
    PICTURE_SIZE,
    RenderStyle,
    corner_colors,
    crease_normals,
    engine_setup,
    light_direction,
    linear_to_srgb,
    picture_camera,
    picture_poses,
    srgb8_to_linear,
    srgb_to_linear,
    texture_lookup,
)
from vptoolkit.point_cloud import PointCloud
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import as_directions
from vptoolkit.visibility import face_id_images
from vptoolkit.visibility.splats import PointScene

__all__ = ["SoftwareRenderer"]

_DEFAULT_SUN = RenderStyle().light_intensity
_DEFAULT_AMBIENT = RenderStyle().ambient_intensity
_SUN = 0.78  # diffuse weight of the default sun
_AMBIENT = 0.30  # weight of the default ambient light
_MAX_FINE = 4096  # largest rasterised side; bigger pictures get fewer samples per pixel,
# and a view is magnified at most to this side (a model that needs more fills less)
_CHUNK = 1 << 20  # pixels shaded at once


class SoftwareRenderer:
    """Draws meshes from view directions on the CPU, in this process.

    The ``"software"`` :class:`~vptoolkit.pictures.engine.Engine` (``size``,
    ``camera``, ``style``, :meth:`start`, :meth:`close`, :meth:`render`, use
    as a context manager), so every picture function's ``engine`` may be
    it or the Open3D one.

    Parameters
    ----------
    size, camera, style
        As :func:`~vptoolkit.pictures.engine.open_renderer` takes them.
    supersampling : int
        Samples per pixel along each axis, 1 to 4 (default: 2); pictures
        wider than 2048 px get fewer, so the rasterised side stays <= 4096.

    Examples
    --------
    >>> with SoftwareRenderer(size=256) as renderer:           # doctest: +SKIP
    ...     images = renderer.render(mesh, [[0, 0, 1], [1, 1, 1]])
    """

    def __init__(self, *, size: int = PICTURE_SIZE, camera: Camera | None = None,
                 style: RenderStyle | None = None, supersampling: int = 2) -> None:
        self.size, self.camera, self.style = engine_setup(size, camera, style)
        self.supersampling = check_int(supersampling, "supersampling", minimum=1, maximum=4)
        self._mesh: Mesh | None = None
        self._corners: NDArray[np.float64] | None = None
        self._corner_normals: NDArray[np.float64] | None = None
        self._paint: _Paint | None = None  # the colours of _paint_source on _painted
        self._painted: Mesh | None = None
        self._paint_source: Appearance | None = None
        self._cloud: PointCloud | None = None  # the cloud of _scene
        self._scene: PointScene | None = None
        self._point_colors: NDArray[np.float64] | None = None  # linear RGB of _point_source
        self._point_source: Appearance | None = None

    def start(self) -> SoftwareRenderer:
        """Nothing to start; returns self (as :class:`~vptoolkit.pictures.engine.Engine` asks)."""
        return self

    def close(self) -> None:
        """Forget the cached mesh, cloud and colours."""
        self._mesh = self._corners = self._corner_normals = None
        self._paint = self._painted = self._paint_source = None
        self._cloud = self._scene = self._point_colors = self._point_source = None

    def __enter__(self) -> SoftwareRenderer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _prepare(self, mesh: Mesh) -> None:
        """Corner positions and crease-aware corner normals per face (-1 rows: not drawn)."""
        if self._mesh is mesh:
            return
        positions, normals, _, _, kept = crease_normals(mesh, self.style.crease_angle_deg)
        self._corners = np.zeros((mesh.n_faces, 3, 3))
        self._corner_normals = np.zeros((mesh.n_faces, 3, 3))
        self._corners[kept] = positions.reshape(-1, 3, 3)
        self._corner_normals[kept] = normals.reshape(-1, 3, 3)
        self._mesh = mesh

    def _prepare_cloud(self, cloud: PointCloud, appearance: Appearance | None) -> None:
        """The cloud's splats (seen through the picture camera) and its points' colours."""
        if self._cloud is not cloud:
            camera = picture_camera(self.camera, self.style.up)
            self._scene = PointScene(cloud.points, cloud.normals, camera)
            self._cloud, self._point_source = cloud, None
            self._point_colors = None
        if self._point_source is not appearance:
            # each point as a degenerate face: its corners all the point's colour
            corners = corner_colors(appearance, np.repeat(np.arange(cloud.n_points)[:, None], 3,
                                                          axis=1), cloud.n_points)
            self._point_colors = None if corners is None else corners[:, 0]
            self._point_source = appearance

    def render(self, mesh: MeshLike | PointCloud, directions: ArrayLike, *,
               appearance: Appearance | None = None) -> NDArray[np.uint8]:
        """Draw a mesh or point cloud from each of several view directions: ``(n, size, size,
        3)`` uint8 sRGB pictures, in its ``appearance`` where given, as :meth:`Engine.render
        <vptoolkit.pictures.engine.Engine.render>` specifies (a cloud as splats, module
        docstring)."""
        unit = as_directions(directions, name="directions")
        camera = picture_camera(self.camera, self.style.up)
        model: Mesh | PointCloud
        if isinstance(mesh, PointCloud):
            model = mesh
            self._prepare_cloud(model, appearance)
            scene = self._scene
            assert scene is not None  # noqa: S101  (made by _prepare_cloud)

            def id_image(direction: NDArray[np.float64], side: int) -> NDArray[np.int32]:
                return scene.id_images(direction, side)[0]

            shade: _Shader = self._shade_points
        else:
            model = as_mesh(mesh)
            self._prepare(model)
            if self._painted is not model or self._paint_source is not appearance:
                self._paint = _Paint.of(appearance, model)
                self._painted, self._paint_source = model, appearance
            drawn = model

            def id_image(direction: NDArray[np.float64], side: int) -> NDArray[np.int32]:
                settings = MeasureSettings(views=1, resolution=side, camera=camera)
                return face_id_images(drawn, settings, view_directions=direction)[0]

            shade = self._shade
        factor = max(1, min(self.supersampling, _MAX_FINE // self.size))
        fine = self.size * factor
        poses, zoom = picture_poses(self.camera, self.style, model, unit, fine)
        images = np.empty((len(unit), self.size, self.size, 3), dtype=np.uint8)
        for view in range(len(unit)):
            ids, focal = self._id_image(id_image, unit[view], fine, float(zoom[view]),
                                        poses.focal_px)
            linear = self._background_image(len(ids))
            hit = np.flatnonzero(ids >= 0)
            for start in range(0, len(hit), _CHUNK):  # bounded memory at any size
                chunk = hit[start:start + _CHUNK]
                linear[chunk] = shade(chunk, ids[chunk], poses, view, focal)
            images[view] = linear_to_srgb(_downsample(linear, self.size, factor))
        return images

    @staticmethod
    def _id_image(id_image: Callable[[NDArray[np.float64], int], NDArray[np.int32]],
                  direction: NDArray[np.float64], fine: int, zoom: float,
                  focal: float) -> tuple[NDArray[np.int32], float]:
        """The ``fine``-side ID image (flat) of one view magnified ``zoom`` times about
        its centre, and its focal length in pixels; ``id_image(direction, side)`` draws
        the ``side``-side image of the view with the picture's field of view."""
        side = min(fine + 2 * int(np.floor((zoom - 1.0) * fine / 2.0)), _MAX_FINE)
        side = max(side - (side - fine) % 2, 2 - fine % 2)
        raster = id_image(direction, side)
        offset = (side - fine) // 2
        if offset >= 0:
            ids = raster[offset:offset + fine, offset:offset + fine]
        else:
            ids = np.full((fine, fine), -1, dtype=np.int32)
            ids[-offset:-offset + side, -offset:-offset + side] = raster
        return ids.reshape(-1), focal * side / fine

    def _background_image(self, n_pixels: int) -> NDArray[np.float64]:
        """``(n_pixels, 3)`` linear RGB of the background."""
        background = np.array([srgb_to_linear(c) for c in self.style.background])
        return np.broadcast_to(background, (n_pixels, 3)).copy()

    def _shade(self, hit: NDArray[np.int64], faces: NDArray[np.int32], poses: ViewPoses,
               view: int, focal: float) -> NDArray[np.float64]:
        """``(len(hit), 3)`` linear RGB of the fine pixels ``hit`` (flat indices), which
        see ``faces``, at focal length ``focal`` pixels."""
        assert self._corners is not None and self._corner_normals is not None  # noqa: S101
        ray = _pixel_rays(hit, poses, view, focal)
        corners = np.take(self._corners, faces, axis=0)  # take: faster than [faces]
        a = corners[:, 0]
        edge1, edge2 = corners[:, 1] - a, corners[:, 2] - a
        p = _cross(ray, edge2)
        determinant = np.einsum("ij,ij->i", edge1, p)
        determinant = np.where(np.abs(determinant) > 1e-300, determinant, 1e-300)
        t = poses.eyes[view][None, :] - a
        u = np.einsum("ij,ij->i", t, p) / determinant
        v = np.einsum("ij,ij->i", ray, _cross(t, edge1)) / determinant
        u, v = np.clip(u, 0.0, 1.0), np.clip(v, 0.0, 1.0)
        normals = np.take(self._corner_normals, faces, axis=0)
        w = 1.0 - u - v
        normal = (w[:, None] * normals[:, 0] + u[:, None] * normals[:, 1]
                  + v[:, None] * normals[:, 2])
        if self._paint is None:
            colour = self._style_colour()
        else:
            colour = self._paint.colors(faces, np.stack([w, u, v], axis=1))
        return self._lit(colour, normal, ray, poses, view)

    def _shade_points(self, hit: NDArray[np.int64], points: NDArray[np.int32],
                      poses: ViewPoses, view: int, focal: float) -> NDArray[np.float64]:
        """``(len(hit), 3)`` linear RGB of the fine pixels ``hit`` (flat indices), which
        see the splats of ``points``: lit along the points' normals, or as a surface
        across the view axis where the cloud has none."""
        ray = _pixel_rays(hit, poses, view, focal)
        normals = None if self._cloud is None else self._cloud.normals
        normal = (np.tile(-poses.forward[view], (len(hit), 1)) if normals is None
                  else np.take(normals, points, axis=0))
        colour = self._style_colour() if self._point_colors is None \
            else np.take(self._point_colors, points, axis=0)
        return self._lit(colour, normal, ray, poses, view)

    def _style_colour(self) -> NDArray[np.float64]:
        """``(1, 3)`` linear RGB of the style's colour."""
        return np.array([srgb_to_linear(c) for c in self.style.color])[None, :]

    def _lit(self, colour: NDArray[np.float64], normal: NDArray[np.float64],
             ray: NDArray[np.float64], poses: ViewPoses, view: int) -> NDArray[np.float64]:
        """Linear RGB ``colour * (ambient + sun * max(0, n . l))`` of pixels of ``colour``
        ``(n, 3)`` or ``(1, 3)`` whose surface has ``normal`` ``(n, 3)`` (any length, turned
        towards the camera along the pixel's ``ray``)."""
        style = self.style
        normal = normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
        facing = np.einsum("ij,ij->i", normal, ray)
        normal[facing > 0] *= -1.0  # a back face seen with culling off
        towards_light = -light_direction(style, poses.forward[view], poses.up[view],
                                         poses.right[view])
        diffuse = np.clip(normal @ towards_light, 0.0, None)
        sun = _SUN * style.light_intensity / _DEFAULT_SUN
        ambient = _AMBIENT * style.ambient_intensity / _DEFAULT_AMBIENT
        return colour * (ambient + sun * diffuse)[:, None]


def _pixel_rays(hit: NDArray[np.int64], poses: ViewPoses, view: int,
                focal: float) -> NDArray[np.float64]:
    """``(len(hit), 3)`` float64 rays (not unit) through the centres of the pixels ``hit``
    (flat indices) of view ``view`` at focal length ``focal`` pixels, as
    :meth:`ViewPoses.pixel_rays <vptoolkit.camera.ViewPoses.pixel_rays>` makes them."""
    row, column = np.divmod(hit, poses.resolution)
    half = poses.resolution / 2.0
    across = (column + 0.5 - half) / focal
    down = (row + 0.5 - half) / focal
    return (poses.forward[view][None, :] + across[:, None] * poses.right[view][None, :]
            - down[:, None] * poses.up[view][None, :])


def _downsample(linear: NDArray[np.float64], size: int, factor: int) -> NDArray[np.float64]:
    """``(size, size, 3)`` means of the ``factor x factor`` blocks of the flat
    ``(size * factor) ** 2``-pixel image ``linear`` ``(n, 3)``: the samples summed one
    after another in row-major order, then divided by ``factor ** 2``, which is what
    ``reshape(size, factor, size, factor, 3).mean(axis=(1, 3))`` computes, bit for bit,
    in half its time."""
    blocks = linear.reshape(size, factor, size, factor, 3)
    total = blocks[:, 0, :, 0].copy()
    for row in range(factor):
        for column in range(factor):
            if row or column:
                total += blocks[:, row, :, column]
    total /= factor * factor
    return total


def _cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Row-wise cross products ``a x b`` of ``(n, 3)`` arrays: the products and
    differences of :func:`numpy.cross` in its order (so the same bits), without its
    axis handling, which costs more than the arithmetic at a million rows."""
    out = np.empty((len(a), 3))
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        np.multiply(a[:, i], b[:, j], out=out[:, k])
        out[:, k] -= a[:, j] * b[:, i]
    return out


_Shader = Callable[[NDArray[np.int64], NDArray[np.int32], ViewPoses, int, float],
                   NDArray[np.float64]]
"""Linear RGB of hit pixels from their flat indices, the IDs they see, the poses, the view
and the focal length (:meth:`SoftwareRenderer._shade`, :meth:`SoftwareRenderer._shade_points`)."""


class _Paint:
    """A model's own colours, ready to colour pixels by face and barycentric coordinates."""

    def __init__(self, corners: NDArray[np.float64], appearance: Appearance) -> None:
        self.corners = corners
        self.corner_uv = appearance.corner_uv
        self.texture = None if appearance.texture is None or self.corner_uv is None else \
            srgb8_to_linear(appearance.texture[..., :3])

    @classmethod
    def of(cls, appearance: Appearance | None, mesh: Mesh) -> _Paint | None:
        """The paint of an appearance on a mesh; None where it has no colour."""
        corners = corner_colors(appearance, mesh.faces, mesh.n_vertices)
        return None if corners is None or appearance is None else cls(corners, appearance)

    def colors(self, faces: NDArray[np.int32],
               weights: NDArray[np.float64]) -> NDArray[np.float64]:
        """``(n, 3)`` linear RGB at barycentric ``weights`` ``(n, 3)`` of ``faces``."""
        colour = np.einsum("ik,ikc->ic", weights, np.take(self.corners, faces, axis=0))
        if self.texture is not None and self.corner_uv is not None:
            uv = np.einsum("ik,ikc->ic", weights, np.take(self.corner_uv, faces, axis=0))
            textured = np.isfinite(uv).all(axis=1)
            colour[textured] *= texture_lookup(self.texture, uv[textured])
        return colour
