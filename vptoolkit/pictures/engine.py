"""What a picture engine is, and how to get one by name.

An engine draws a :class:`~vptoolkit.mesh.Mesh` from view directions
through the measures' camera (:func:`vptoolkit.pictures.shading.picture_camera`)
in a :class:`~vptoolkit.pictures.shading.RenderStyle`, in the model's own
:class:`~vptoolkit.appearance.Appearance` where one is given. Two satisfy
:class:`Engine`:

* ``"software"``: :class:`vptoolkit.pictures.software_engine.SoftwareRenderer`,
  the measures' rasteriser and numpy shading, in this process (the default);
  it draws vertex, face and base colours and base-colour textures;
* ``"open3d"``: :class:`vptoolkit.pictures.open3d_engine.Renderer`, Open3D's
  Filament in a child process; it draws vertex, face and base colours and
  samples a texture at the triangle corners only. On Mesa's software
  Vulkan driver its frame time depends on the view, from 0.1 s to
  minutes, which is why it is not the default.

The software engine also draws a :class:`~vptoolkit.point_cloud.PointCloud`,
as the measures' splats in its per-point colours; the Open3D engine refuses
one in one line. Neither draws transparency (alpha is ignored), normal,
metallic or emissive maps.

:func:`open_renderer` makes either. Every picture function takes one
``engine`` (its size, camera and style apply) and leaves it open for its
owner, or makes the default engine for the call (:func:`drawing_engine`).
``tests/pictures/test_engine.py`` checks what every engine must do.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from vptoolkit.errors import InputError
from vptoolkit.pictures.shading import PICTURE_SIZE

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike, NDArray

    from vptoolkit.appearance import Appearance
    from vptoolkit.camera import Camera
    from vptoolkit.mesh import MeshLike
    from vptoolkit.pictures.shading import RenderStyle
    from vptoolkit.point_cloud import PointCloud

__all__ = ["ENGINES", "Engine", "drawing_engine", "open_renderer"]

ENGINES = ("software", "open3d")
"""Picture engines, the default first: ``"software"``
(:class:`~vptoolkit.pictures.software_engine.SoftwareRenderer`) and ``"open3d"``
(:class:`~vptoolkit.pictures.open3d_engine.Renderer`)."""


@runtime_checkable
class Engine(Protocol):
    """A picture engine: draws models from view directions, one size for all pictures.

    Attributes
    ----------
    size : int
        Side of the square pictures in pixels (16 to 4096).
    camera : Camera
        Camera conventions (those of the measures by default); the picture
        for direction ``v`` frames the model as the measures' view ``v`` does.
    style : RenderStyle
        Colours, light, crease angle and image up.

    Notes
    -----
    An engine is a context manager: :meth:`close` runs on exit and frees
    what :meth:`start` (or the first :meth:`render`) took; a closed engine
    may be started again. The same mesh and direction give the same picture,
    byte for byte.
    """

    size: int
    camera: Camera
    style: RenderStyle

    def start(self) -> Engine:
        """Make the engine ready now (else the first frame does); returns itself.

        Raises
        ------
        MissingDependencyError
            If the engine cannot run here (e.g. no Vulkan driver).
        """
        ...

    def close(self) -> None:
        """Free the engine's resources (it may be started again)."""
        ...

    def render(self, mesh: MeshLike | PointCloud, directions: ArrayLike, *,
               appearance: Appearance | None = None) -> NDArray[np.uint8]:
        """Draw a mesh (or a point cloud, where the engine draws clouds) from each of
        several view directions.

        Parameters
        ----------
        mesh : MeshLike or PointCloud
            The model.
        directions : (n, 3) or (3,) array_like
            View directions from the model centre towards the camera (any
            non-zero length).
        appearance : Appearance, optional
            The model's colours and texture, indexed like ``mesh``
            (:func:`vptoolkit.io.load_with_appearance`); None, or one
            without colours, draws the style's colour.

        Returns
        -------
        images : (n, size, size, 3) uint8
            sRGB pictures, row 0 at the top, background where no face (or
            splat) is seen.

        Raises
        ------
        InputError
            On a non-mesh, bad directions, a mesh of zero extent, an
            appearance whose arrays do not match the model, or a point
            cloud given to an engine that draws surfaces only.
        """
        ...

    def __enter__(self) -> Engine:
        ...

    def __exit__(self, *exc_info: object) -> None:
        ...


def open_renderer(engine: str = "software", *, size: int = PICTURE_SIZE,
                  camera: Camera | None = None, style: RenderStyle | None = None) -> Engine:
    """A renderer of the given engine (not started), for use as a context manager.

    Parameters
    ----------
    engine : {"software", "open3d"}
        ``"software"`` (default) draws in this process in a fraction of a
        second for any view; ``"open3d"`` uses Filament's physically based
        shading through Vulkan, whose frame time on Mesa's software driver
        ranges from 0.1 s to minutes depending on the view.
    size, camera, style
        Picture side in pixels (default: 512), camera (default: the
        measures') and shading (default: ``RenderStyle()``), checked by
        :func:`~vptoolkit.pictures.shading.engine_setup`.

    Returns
    -------
    Engine
        A :class:`~vptoolkit.pictures.software_engine.SoftwareRenderer` or a
        :class:`~vptoolkit.pictures.open3d_engine.Renderer`.

    Raises
    ------
    InputError
        On an unknown engine.
    """
    if engine == "open3d":
        from vptoolkit.pictures.open3d_engine import Renderer

        return Renderer(size=size, camera=camera, style=style)
    if engine == "software":
        from vptoolkit.pictures.software_engine import SoftwareRenderer

        return SoftwareRenderer(size=size, camera=camera, style=style)
    raise InputError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")


@contextmanager
def drawing_engine(engine: Engine | None, *, size: int = PICTURE_SIZE,
                   camera: Camera | None = None) -> Iterator[Engine]:
    """The engine a picture function draws with, as a context manager.

    Parameters
    ----------
    engine : Engine, optional
        The caller's engine, used as it is and left open for its owner; None
        makes a software engine of ``size`` and ``camera`` for the ``with``
        block and closes it after.
    size : int
        Picture side of the engine made when ``engine`` is None (default: 512).
    camera : Camera, optional
        The camera the pictures must use: the measures' camera where a
        picture shows a measured view (default: ``Camera()``).

    Raises
    ------
    InputError
        If ``engine`` is not an engine (e.g. a name: make one with
        :func:`open_renderer`), or its camera is not ``camera``, so its
        pictures would not show the views the measures scored.
    """
    if engine is None:
        with open_renderer(size=size, camera=camera) as own:
            yield own
        return
    if not isinstance(engine, Engine):
        raise InputError(f"engine: expected an Engine (see open_renderer), got "
                         f"{type(engine).__name__}")
    if camera is not None and engine.camera != camera:
        raise InputError("engine: its camera differs from the camera of the measures, so its "
                         "pictures would not show the views they scored")
    yield engine
