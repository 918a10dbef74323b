"""Pictures of a model from chosen view directions: given, best for a measure, or predicted.

A picture for view direction ``v`` shows what the measures scored for ``v``:
the eye, target and field of view are those of
:class:`vptoolkit.camera.Camera` (``Camera().poses(v, centre=, diagonal=,
resolution=size)`` with the bounding frame of
:func:`vptoolkit.geometry.bounding_frame`). Back faces are culled when the
camera culls them (the default), exactly as the measures do, so a face the
measures counted as invisible is missing from the picture too.

Framing (``RenderStyle.margin``, default 0.05 of the side) magnifies each
picture about its centre so the model fills it up to the margin; the eye
stays where the measures put it, so the same faces are seen.
``RenderStyle(margin=None)`` keeps the measures' framing.

Only the roll differs: the measures keep the authors' image up ``-y``, which
shows the usual ``+y``-up model (glTF, OBJ, PLY scans) upside down, so a
picture's image up is ``RenderStyle.up`` (default ``+y``; ``(0, 0, 1)`` for
ModelNet-style ``+z``-up models). The roll does not change what is seen:
the camera's distance keeps the model's bounding sphere inside the circle
inscribed in the image. With ``RenderStyle(up=Camera().up)`` pixel ``(x,
y)`` of a picture ``size`` pixels wide is pixel ``(x, y)`` of the measures'
triangle-ID image at resolution ``size`` (with ``margin=None``).

A model is a mesh or a point cloud (:func:`vptoolkit.io.objects.model_of`
takes either, or another library's object): the software engine draws a
cloud as the measures' splats, so a cloud's best view is found and drawn
the same way.

Every function takes the model's ``appearance``
(:func:`vptoolkit.io.load_with_appearance`) to draw it in its own colours.

Every function takes an ``engine`` (any :class:`~vptoolkit.pictures.engine.Engine`,
made with :func:`~vptoolkit.pictures.engine.open_renderer`; its size, camera
and style apply) and leaves it open, or draws with a software engine made for
the call; the measured views' functions take a
:class:`~vptoolkit.settings.MeasureSettings`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.appearance import Appearance
from vptoolkit.errors import InputError
from vptoolkit.io import require_surface
from vptoolkit.io.objects import model_of
from vptoolkit.measures.quality import ViewQuality
from vptoolkit.measures.registry import PAPER_MEASURES, canonical_name, measure_index
from vptoolkit.mesh import Mesh, MeshLike
from vptoolkit.pictures.engine import Engine, drawing_engine
from vptoolkit.point_cloud import PointCloud
from vptoolkit.settings import MeasureSettings, check_settings
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
"""A view direction for a model: ``(3,)`` or ``(M, 3)`` (one per measure, by default
the paper's four in ``PAPER_MEASURES`` order), or a callable returning either from a
:class:`~vptoolkit.mesh.Mesh` (e.g. a trained network's prediction; it takes meshes)."""


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


def render_views(mesh: MeshLike | PointCloud, directions: ArrayLike, *,
                 engine: Engine | None = None,
                 appearance: Appearance | None = None) -> NDArray[np.uint8]:
    """Draw a mesh from several view directions with one engine.

    Parameters
    ----------
    mesh : MeshLike or PointCloud
        The model: a mesh, or a point cloud (drawn as splats by the engines that
        draw clouds, :mod:`vptoolkit.pictures.engine`).
    directions : (n, 3) or (3,) array_like
        View directions from the model centre towards the camera.
    engine : Engine, optional
        The engine to draw with (its size, camera and style apply), left
        open; default: a software engine of the default size, the measures'
        camera and the default style, made for this call.
    appearance : Appearance, optional
        The model's colours and texture (default: the style's colour).

    Returns
    -------
    images : (n, size, size, 3) uint8
    """
    mesh = model_of(mesh)
    with drawing_engine(engine) as active:
        return active.render(mesh, directions, appearance=appearance)


def render_view(mesh: MeshLike | PointCloud, direction: ArrayLike, *,
                engine: Engine | None = None,
                appearance: Appearance | None = None) -> NDArray[np.uint8]:
    """Draw a mesh from one view direction.

    Parameters
    ----------
    mesh : MeshLike or PointCloud
        The model: a mesh, or a point cloud (drawn as splats by the engines that
        draw clouds, :mod:`vptoolkit.pictures.engine`).
    direction : (3,) array_like
        View direction from the model centre towards the camera.
    engine, appearance
        As for :func:`render_views`.

    Returns
    -------
    image : (size, size, 3) uint8
        sRGB picture, row 0 at the top.

    Raises
    ------
    InputError
        On a bad direction.
    MissingDependencyError
        If the engine cannot start here (e.g. no Vulkan driver).
    MeasurementError
        If the frame failed in every attempt.
    """
    mesh = model_of(mesh)
    unit = as_directions(direction, name="direction")
    if len(unit) != 1:
        raise InputError(f"direction: expected one direction, got {len(unit)}")
    return render_views(mesh, unit, engine=engine, appearance=appearance)[0]


def resolve_direction(mesh: MeshLike | PointCloud, source: DirectionSource, *,
                      measure: str = "VE",
                      measures: Sequence[str] | None = None) -> NDArray[np.float64]:
    """The view direction a direction source gives for a mesh and measure.

    Parameters
    ----------
    mesh : MeshLike or PointCloud
        The model (passed to ``source`` if it is callable).
    source : (3,) or (M, 3) array_like, or callable
        A direction, one direction per measure of ``measures``, or a callable
        ``source(mesh)`` returning either (the hook for a trained network,
        e.g. :class:`vptoolkit.learn.predict.MeshPredictor`).
    measure : str
        Measure whose row to take from an ``(M, 3)`` result, any registered
        name in any case (default: "VE").
    measures : sequence of str, optional
        The measures of the rows of an ``(M, 3)`` result (default: the
        source's own ``measures`` attribute, as a
        :class:`~vptoolkit.learn.predict.MeshPredictor` has, else the
        paper's four, :data:`~vptoolkit.measures.registry.PAPER_MEASURES`).

    Returns
    -------
    direction : (3,) float64
        Unit vector.

    Raises
    ------
    InputError
        On an unknown measure or one the source does not give, a wrong shape,
        or a zero or non-finite vector; a point cloud with a callable source
        (:class:`~vptoolkit.errors.MeshLoadError`: it takes meshes).
    """
    mesh = model_of(mesh)
    rows = tuple(getattr(source, "measures", PAPER_MEASURES) if measures is None else measures)
    column = measure_index(measure, rows)
    value = source(require_surface(mesh)) if callable(source) else source
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f"{mesh.name}: predicted direction is not numeric ({err})") from err
    if array.shape == (len(rows), 3):
        array = array[column]
    elif array.shape == (1, 3):
        array = array[0]
    if array.shape != (3,):
        raise InputError(f"{mesh.name}: expected a (3,) or ({len(rows)}, 3) direction, "
                         f"got shape {array.shape}")
    return as_directions(array, name=f"{mesh.name}: direction")[0]


def render_best(
    mesh: MeshLike | PointCloud,
    *,
    measure: str = "VE",
    quality: ViewQuality | None = None,
    settings: MeasureSettings | None = None,
    engine: Engine | None = None,
    appearance: Appearance | None = None,
) -> RenderedView:
    """Draw a mesh from its best view for one measure.

    The measures are computed first (:func:`vptoolkit.measures.quality.compute_view_quality`
    with ``settings``) unless ``quality`` is given; the picture uses their camera.

    Parameters
    ----------
    mesh : MeshLike or PointCloud
        The model: a mesh, or a point cloud (drawn as splats by the engines that
        draw clouds, :mod:`vptoolkit.pictures.engine`).
    measure : str
        Any registered measure name, in any case (default: "VE").
    quality : ViewQuality, optional
        Measures already computed for this mesh, ``measure`` among them.
    settings : MeasureSettings, optional
        How to measure when ``quality`` is not given (default:
        ``MeasureSettings()``: 1000 views at 1024 px, ``Camera()``).
    engine : Engine, optional
        The engine to draw with, whose camera must be the measures'
        (default: a software engine with their camera, made for this call).
    appearance : Appearance, optional
        The model's colours and texture (default: the style's colour).

    Returns
    -------
    RenderedView
        ``label`` reads e.g. ``"best VE (view 17 of 1000)"``.

    Raises
    ------
    InputError
        On an unknown measure, or an engine whose camera is not the measures'.
    """
    mesh = model_of(mesh)
    measure = canonical_name(measure)
    settings = MeasureSettings() if settings is None else check_settings(settings)
    if quality is None:
        from vptoolkit.measures.quality import compute_view_quality

        quality = compute_view_quality(mesh, settings, measures=(measure,))
    index = int(quality.best_index[measure_index(measure, quality.measures)])
    direction = quality.views[index]
    with drawing_engine(engine, camera=quality.camera) as active:
        image = render_view(mesh, direction, engine=active, appearance=appearance)
    return RenderedView(image, direction.copy(),
                        f"best {measure} (view {index} of {len(quality.views)})")


def render_predicted(
    mesh: MeshLike | PointCloud,
    source: DirectionSource,
    *,
    measure: str = "VE",
    engine: Engine | None = None,
    appearance: Appearance | None = None,
) -> RenderedView:
    """Draw a mesh from a predicted view direction.

    Parameters
    ----------
    mesh : MeshLike or PointCloud
        The model: a mesh, or a point cloud (drawn as splats by the engines that
        draw clouds, :mod:`vptoolkit.pictures.engine`).
    source : (3,) or (M, 3) array_like, or callable
        See :func:`resolve_direction`; a callable gets the mesh and returns
        the prediction (the hook for ``vptool render --model``).
    measure : str
        Measure whose prediction to draw, in any case (default: "VE"); one
        of the source's measures (:func:`resolve_direction`).
    engine, appearance
        As for :func:`render_views`.

    Returns
    -------
    RenderedView
        ``label`` reads e.g. ``"predicted VE"``.
    """
    mesh = model_of(mesh)
    direction = resolve_direction(mesh, source, measure=measure)
    image = render_view(mesh, direction, engine=engine, appearance=appearance)
    return RenderedView(image, direction, f"predicted {canonical_name(measure)}")
