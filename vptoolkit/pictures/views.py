"""Pictures of a mesh from chosen view directions: given, best for a measure, or predicted.

A picture for view direction ``v`` shows what the measures scored for ``v``:
the eye, target and field of view are those of
:class:`vptoolkit.camera.Camera` (``Camera().poses(v, centre=, diagonal=,
resolution=size)`` with the bounding frame of
:func:`vptoolkit.geometry.bounding_frame`). Back faces are culled when the
camera culls them (the default), exactly as the measures do, so a face the
measures counted as invisible is missing from the picture too.

Only the roll differs: the measures keep the authors' image up ``-y``, which
shows the usual ``+y``-up model (glTF, OBJ, PLY scans) upside down, so a
picture's image up is ``RenderStyle.up`` (default ``+y``; ``(0, 0, 1)`` for
ModelNet-style ``+z``-up models). The roll does not change what is seen:
the camera's distance keeps the model's bounding sphere inside the circle
inscribed in the image. With ``RenderStyle(up=Camera().up)`` pixel ``(x,
y)`` of a picture ``size`` pixels wide is pixel ``(x, y)`` of the measures'
triangle-ID image at resolution ``size``.

Every function takes an open ``renderer`` (any :class:`~vptoolkit.pictures.engine.Engine`)
to reuse, or makes one of ``engine`` for the call
(:func:`~vptoolkit.pictures.engine.open_renderer`; default ``"software"``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.camera import Camera
from vptoolkit.conventions import MEASURES, N_VIEWS, RESOLUTION, measure_index
from vptoolkit.errors import InputError
from vptoolkit.measures import ViewQuality
from vptoolkit.mesh import Mesh
from vptoolkit.pictures.engine import Engine, open_renderer
from vptoolkit.pictures.shading import PICTURE_SIZE, RenderStyle
from vptoolkit.sphere import as_directions

__all__ = [
    "DirectionSource",
    "RenderedView",
    "render_best",
    "render_predicted",
    "render_view",
    "render_views",
    "resolve_direction",
]

DirectionSource = Callable[[Mesh], ArrayLike] | ArrayLike
"""A view direction for a mesh: ``(3,)`` or ``(4, 3)`` (one per measure, in
``MEASURES`` order), or a callable returning either from a
:class:`~vptoolkit.mesh.Mesh` (e.g. a trained network's prediction)."""


@dataclass(frozen=True, eq=False)
class RenderedView:
    """A picture and the direction it was taken from.

    Attributes
    ----------
    image : (size, size, 3) uint8
        sRGB picture, row 0 at the top.
    direction : (3,) float64
        Unit view direction from the model centre towards the camera.
    label : str
        What chose the direction, e.g. ``"best VE (view 17)"``, ``"model VE"``.
    """

    image: NDArray[np.uint8]
    direction: NDArray[np.float64]
    label: str


def render_views(
    mesh: Mesh,
    directions: ArrayLike,
    *,
    size: int = PICTURE_SIZE,
    camera: Camera | None = None,
    style: RenderStyle | None = None,
    renderer: Engine | None = None,
    engine: str = "software",
) -> NDArray[np.uint8]:
    """Draw a mesh from several view directions with one renderer.

    Parameters
    ----------
    mesh : Mesh
        The model.
    directions : (n, 3) or (3,) array_like
        View directions from the model centre towards the camera.
    size : int
        Picture side in pixels (default: 512); ignored when ``renderer`` is given.
    camera : Camera, optional
        Camera conventions (default: those of the measures).
    style : RenderStyle, optional
        Shading.
    renderer : Engine, optional
        An open renderer to reuse (its size, camera and style apply).
    engine : {"software", "open3d"}
        Engine of a renderer made for this call (default: "software"; see
        :func:`open_renderer`).

    Returns
    -------
    images : (n, size, size, 3) uint8
    """
    if renderer is not None:
        return renderer.render(mesh, directions)
    with open_renderer(engine, size=size, camera=camera, style=style) as own:
        return own.render(mesh, directions)


def render_view(
    mesh: Mesh,
    direction: ArrayLike,
    *,
    size: int = PICTURE_SIZE,
    camera: Camera | None = None,
    style: RenderStyle | None = None,
    renderer: Engine | None = None,
    engine: str = "software",
) -> NDArray[np.uint8]:
    """Draw a mesh from one view direction.

    Parameters
    ----------
    mesh : Mesh
        The model.
    direction : (3,) array_like
        View direction from the model centre towards the camera.
    size : int
        Picture side in pixels (default: 512); ignored when ``renderer`` is given.
    camera : Camera, optional
        Camera conventions (default: ``Camera()``, those of the measures).
    style : RenderStyle, optional
        Shading.
    renderer : Engine, optional
        An open renderer to reuse.
    engine : {"software", "open3d"}
        Engine of a renderer made for this call (default: "software").

    Returns
    -------
    image : (size, size, 3) uint8
        sRGB picture, row 0 at the top.

    Raises
    ------
    InputError
        On a bad direction.
    MissingDependencyError
        If no renderer can start here (e.g. no Vulkan driver).
    MeasurementError
        If the frame failed in every attempt.
    """
    unit = as_directions(direction, name="direction")
    if len(unit) != 1:
        raise InputError(f"direction: expected one direction, got {len(unit)}")
    return render_views(mesh, unit, size=size, camera=camera, style=style,
                        renderer=renderer, engine=engine)[0]


def resolve_direction(mesh: Mesh, source: DirectionSource, *,
                      measure: str = "VE") -> NDArray[np.float64]:
    """The view direction a direction source gives for a mesh and measure.

    Parameters
    ----------
    mesh : Mesh
        The model (passed to ``source`` if it is callable).
    source : (3,) or (4, 3) array_like, or callable
        A direction, one direction per measure in ``MEASURES`` order, or a
        callable ``source(mesh)`` returning either (the hook for a trained
        network, e.g. a wrapper around ``vptoolkit.learn.predict``).
    measure : str
        Row to take from a ``(4, 3)`` result (default: "VE").

    Returns
    -------
    direction : (3,) float64
        Unit vector.

    Raises
    ------
    InputError
        On an unknown measure, a wrong shape, or a zero or non-finite vector.
    """
    column = measure_index(measure)
    value = source(mesh) if callable(source) else source
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f"{mesh.name}: predicted direction is not numeric ({err})") from err
    if array.shape == (len(MEASURES), 3):
        array = array[column]
    elif array.shape == (1, 3):
        array = array[0]
    if array.shape != (3,):
        raise InputError(f"{mesh.name}: expected a (3,) or ({len(MEASURES)}, 3) direction, "
                         f"got shape {array.shape}")
    return as_directions(array, name=f"{mesh.name}: direction")[0]


def render_best(
    mesh: Mesh,
    *,
    measure: str = "VE",
    size: int = PICTURE_SIZE,
    quality: ViewQuality | None = None,
    n_views: int = N_VIEWS,
    resolution: int = RESOLUTION,
    camera: Camera | None = None,
    style: RenderStyle | None = None,
    renderer: Engine | None = None,
    engine: str = "software",
) -> RenderedView:
    """Draw a mesh from its best view for one measure.

    The measures are computed first (:func:`vptoolkit.measures.compute_view_quality`
    with ``n_views`` and ``resolution``) unless ``quality`` is given; the
    picture uses the same camera conventions.

    Parameters
    ----------
    mesh : Mesh
        The model.
    measure : str
        ``"VE"``, ``"VR"``, ``"VKL"`` or ``"VMI"`` (default: "VE").
    size : int
        Picture side in pixels (default: 512).
    quality : ViewQuality, optional
        Measures already computed for this mesh.
    n_views, resolution : int
        Views and triangle-ID resolution of the measures (defaults: 1000, 1024).
    camera : Camera, optional
        Camera conventions for both measures and picture (default: ``Camera()``).
    style : RenderStyle, optional
        Shading.
    renderer : Engine, optional
        An open renderer to reuse.
    engine : {"software", "open3d"}
        Engine of a renderer made for this call (default: "software").

    Returns
    -------
    RenderedView
        ``label`` reads e.g. ``"best VE (view 17 of 1000)"``.
    """
    column = measure_index(measure)
    if quality is None:
        from vptoolkit.measures import compute_view_quality
        from vptoolkit.settings import MeasureSettings

        quality = compute_view_quality(
            mesh, MeasureSettings(n_views, resolution, camera or Camera()))
    index = int(quality.best_index[column])
    direction = quality.views[index]
    image = render_view(mesh, direction, size=size, camera=camera or quality.camera,
                        style=style, renderer=renderer, engine=engine)
    return RenderedView(image, direction.copy(),
                        f"best {MEASURES[column]} (view {index} of {len(quality.views)})")


def render_predicted(
    mesh: Mesh,
    source: DirectionSource,
    *,
    measure: str = "VE",
    size: int = PICTURE_SIZE,
    camera: Camera | None = None,
    style: RenderStyle | None = None,
    renderer: Engine | None = None,
    engine: str = "software",
) -> RenderedView:
    """Draw a mesh from a predicted view direction.

    Parameters
    ----------
    mesh : Mesh
        The model.
    source : (3,) or (4, 3) array_like, or callable
        See :func:`resolve_direction`; a callable gets the mesh and returns
        the prediction (the hook for ``vptool render --model``).
    measure : str
        Measure whose prediction to draw (default: "VE").
    size : int
        Picture side in pixels (default: 512).
    camera, style, renderer, engine
        As for :func:`render_view`.

    Returns
    -------
    RenderedView
        ``label`` reads e.g. ``"predicted VE"``.
    """
    direction = resolve_direction(mesh, source, measure=measure)
    image = render_view(mesh, direction, size=size, camera=camera, style=style,
                        renderer=renderer, engine=engine)
    return RenderedView(image, direction, f"predicted {MEASURES[measure_index(measure)]}")

