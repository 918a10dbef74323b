"""Contact sheets: a model's view set drawn as one picture, a captioned tile per view.

:func:`contact_sheet` lays pictures out in a grid with a caption under each
(text drawn by matplotlib's Agg canvas, no display); :func:`view_set_sheet`
finds a mesh's view set (:func:`vptoolkit.view_sets.search.measure_view_set`) and
draws it, each tile through the measures' camera, captioned with the pick,
the view, its direction and the coverage reached so far. The result is an
``(height, width, 3) uint8`` image for :func:`vptoolkit.pictures.png.save_png`;
the same inputs give the same bytes.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.appearance import Appearance
from vptoolkit.checks import check_int
from vptoolkit.errors import InputError
from vptoolkit.io.objects import model_of
from vptoolkit.mesh import MeshLike
from vptoolkit.optional import require
from vptoolkit.pictures.engine import Engine, drawing_engine
from vptoolkit.point_cloud import PointCloud
from vptoolkit.settings import MeasureSettings, check_settings
from vptoolkit.view_sets.result import ViewSet
from vptoolkit.view_sets.search import measure_view_set

__all__ = ["TILE_SIZE", "contact_sheet", "view_set_captions", "view_set_sheet"]

TILE_SIZE: Final = 256
"""Side in pixels of a view-set sheet's tiles when no engine is given."""

_CAPTION_PX = 34  # caption strip under a tile, room for two lines of 9 px text
_TITLE_PX = 26
_GAP_PX = 6
_DPI = 100


def view_set_captions(view_set: ViewSet) -> list[str]:
    """One two-line caption per pick: ``"1 · view 226 · 45.2 % seen"`` and the direction."""
    captions = []
    for position, (index, direction, coverage) in enumerate(
            zip(view_set.indices, view_set.directions, view_set.coverage)):
        x, y, z = direction
        captions.append(f"{position + 1} · view {int(index)} · {100 * coverage:.1f} % seen\n"
                        f"({x:+.2f}, {y:+.2f}, {z:+.2f})")
    return captions


def contact_sheet(
    images: Iterable[ArrayLike],
    captions: Sequence[str],
    *,
    columns: int | None = None,
    title: str | None = None,
) -> NDArray[np.uint8]:
    """Lay square pictures out in a grid, each with a caption under it.

    Parameters
    ----------
    images : (n, size, size, 3) uint8 array_like, or a sequence of them
        The tiles, row 0 at the top.
    captions : sequence of str
        One caption per tile (a line break gives a second line).
    columns : int, optional
        Tiles per row (default: ``min(n, 4)``).
    title : str, optional
        A line above the grid.

    Returns
    -------
    sheet : (height, width, 3) uint8
        White background; tiles ``_GAP_PX`` apart.

    Raises
    ------
    InputError
        On no tiles, tiles of different or non-square shapes, or a caption
        count that differs from the tiles.
    MissingDependencyError
        If matplotlib is missing.
    """
    tiles = [np.asarray(image) for image in images]
    if not tiles:
        raise InputError("images: a contact sheet needs at least one picture")
    size = tiles[0].shape[0]
    if any(t.shape != (size, size, 3) or t.dtype != np.uint8 for t in tiles):
        raise InputError(f"images: expected square (size, size, 3) uint8 pictures of one size, "
                         f"got {sorted({t.shape for t in tiles})}")
    if len(captions) != len(tiles):
        raise InputError(f"captions: {len(captions)} captions for {len(tiles)} pictures")
    n_columns = check_int(columns if columns is not None else min(len(tiles), 4), "columns",
                          minimum=1)
    n_rows = -(-len(tiles) // n_columns)
    top = _TITLE_PX if title else 0
    width = n_columns * size + (n_columns + 1) * _GAP_PX
    height = top + n_rows * (size + _CAPTION_PX) + (n_rows + 1) * _GAP_PX
    require("matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(width / _DPI, height / _DPI), dpi=_DPI, facecolor="white")
    canvas = FigureCanvasAgg(figure)
    for position, (tile, caption) in enumerate(zip(tiles, captions)):
        row, column = divmod(position, n_columns)
        left = _GAP_PX + column * (size + _GAP_PX)
        upper = top + _GAP_PX + row * (size + _CAPTION_PX + _GAP_PX)
        axes = figure.add_axes((left / width, 1 - (upper + size) / height, size / width,
                                size / height))
        axes.imshow(tile, interpolation="nearest")
        axes.set_xticks([])
        axes.set_yticks([])
        for spine in axes.spines.values():
            spine.set_color("#d9dee5")
        figure.text((left + size / 2) / width, 1 - (upper + size + 3) / height, caption,
                    ha="center", va="top", fontsize=8, color="#1d2430", linespacing=1.3)
    if title:
        figure.text(_GAP_PX / width, 1 - 5 / height, title, ha="left", va="top", fontsize=10,
                    color="#1d2430")
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    return np.ascontiguousarray(rgba[:, :, :3])


def view_set_sheet(
    mesh: MeshLike | PointCloud,
    k: int | None = 4,
    *,
    view_set: ViewSet | None = None,
    settings: MeasureSettings | None = None,
    engine: Engine | None = None,
    appearance: Appearance | None = None,
    **options: object,
) -> tuple[NDArray[np.uint8], ViewSet]:
    """Find a model's view set and draw it as a contact sheet.

    Parameters
    ----------
    mesh : MeshLike or PointCloud
        The model (a cloud: its points' view set, drawn as splats).
    k : int or None
        Views in the set (default: 4); see :func:`vptoolkit.view_sets.search.best_view_set`.
    view_set : ViewSet, optional
        A set already found for this mesh; nothing is measured then.
    settings : MeasureSettings, optional
        How the views are measured (default: ``MeasureSettings()``: 1000
        views, 1024 px, ``Camera()``).
    engine : Engine, optional
        The engine that draws the tiles, its size the tiles' side; its
        camera must be that of ``settings`` (default: a software engine of
        :data:`TILE_SIZE` pixels with that camera, made for this call).
    appearance : Appearance, optional
        The model's colours and texture (default: the style's colour).
    **options
        ``objective``, ``until_coverage``, ``measure``, ``tolerance``,
        ``min_pixels`` of the search.

    Returns
    -------
    sheet : (height, width, 3) uint8
        The tiles in selection order, captioned with pick, view, cumulative
        coverage and direction, under a title naming the model and objective.
    view_set : ViewSet
        The set drawn.
    """
    mesh = model_of(mesh)
    settings = MeasureSettings() if settings is None else check_settings(settings)
    with drawing_engine(engine, size=TILE_SIZE, camera=settings.camera) as active:
        if view_set is None:
            _, view_set = measure_view_set(mesh, k, settings=settings,
                                           **options)  # type: ignore[arg-type]
        images = active.render(mesh, view_set.directions, appearance=appearance)
    title = (f"{mesh.name}: {len(view_set)} views by {view_set.objective}, "
             f"{100 * view_set.coverage[-1]:.1f} % of the surface seen "
             f"({100 * view_set.reachable:.1f} % reachable)")
    return contact_sheet(list(images), view_set_captions(view_set), title=title), view_set
