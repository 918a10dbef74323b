"""Every measure's Mercator map on one figure: a grid of panels, four to a row.

:func:`sphere_maps` draws the map of :mod:`vptoolkit.pictures.sphere_map`
once per column of a quality array (the paper's four side by side, all 22
of the registry on six rows), each panel titled with the registry's name
for its measure, with the best sampled view (star), an optional predicted
view (cross) and an optional view set (numbered circles) marked, and one
colour bar for all. :func:`sphere_maps_file` draws the ``.npz`` of
``vptool measures -o``, whatever measures it records.

Layout
    The figure is 12 inches wide and 3.4 inches high per row of four; a
    panel is 0.19 of the width, at ``0.035 + 0.226 * place`` from the left,
    and 0.74 of its row high, so the paper's four make one row of
    1200 x 340 pixels at 100 dpi. The colour bar stands at the right edge.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from vptoolkit.checks import as_path
from vptoolkit.errors import InputError
from vptoolkit.pictures.sphere_map import (
    _MAX_LATITUDE_DEG,
    _check_max_latitude,
    _column,
    _draw_panel,
    _limits,
    _measure_names,
    _new_figure,
    _predicted_rows,
    _quality_matrix,
    read_quality_maps,
    save_figure,
    sphere_grid,
)
from vptoolkit.sphere import as_directions

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["sphere_maps", "sphere_maps_file"]

_PER_ROW = 4  # panels per row
_ROW_INCHES = 3.4  # height of one row of panels


def sphere_maps(
    views: ArrayLike,
    quality: ArrayLike,
    *,
    measures: Sequence[str] | None = None,
    predicted: ArrayLike | None = None,
    title: str | None = None,
    width: int = 180,
    max_latitude_deg: float = _MAX_LATITUDE_DEG,
    view_set: ArrayLike | None = None,
) -> Figure:
    """Every measure's Mercator map on one figure, four to a row, as in a report card.

    Parameters
    ----------
    views : (n_views, 3) array_like
        Sampled view directions.
    quality : (n_views, M) array_like
        Normalised quality, 1 = best, one column per name of ``measures``.
    measures : sequence of str, optional
        The names of the columns (default: the paper's four, ``PAPER_MEASURES``,
        which needs ``M = 4``).
    predicted : (3,) or (M, 3) array_like, optional
        Predicted directions (one for all, or one per measure; NaN rows: none).
    title : str, optional
        Figure title.
    width : int
        Columns of each map over 360 degrees (default: 180, two degrees each).
    max_latitude_deg : float
        Latitude of the maps' edges (default: 85).
    view_set : (k, 3) array_like, optional
        A view set (:mod:`vptoolkit.view_sets`), drawn on every map as
        orange circles numbered in selection order (gids ``"view-set-1"`` ...).

    Returns
    -------
    figure : matplotlib.figure.Figure
        ``M`` map axes with gids ``"map-VE"`` ... (in ``measures`` order, row
        by row, four to a row), each titled with the registry's words for its
        measure, and one shared colour bar for [0, 1]. Each row is 3.4 inches
        high and the figure 12 inches wide, so the paper's four make one row
        of 12 x 3.4 inches, the registry's 22 six rows.
    """
    view_array = as_directions(views, name="views")
    names = _measure_names(measures)
    values = _quality_matrix(quality, len(view_array), len(names))
    if values.shape[1] != len(names):
        raise InputError(f"quality: expected shape ({len(view_array)}, {len(names)}), "
                         f"got {np.shape(quality)}")
    rows = _predicted_rows(predicted, len(names))
    chosen = None if view_set is None else as_directions(view_set, name="view_set")
    max_latitude_deg = _check_max_latitude(max_latitude_deg)
    grid = sphere_grid(view_array, width=width, max_latitude_deg=max_latitude_deg)
    n_rows = math.ceil(len(names) / _PER_ROW)
    figure = _new_figure((12.0, _ROW_INCHES * n_rows))
    limits = _limits(values)
    height = 1.0 / n_rows  # one row, in figure fractions
    for column, measure in enumerate(names):
        row, place = divmod(column, _PER_ROW)
        bottom = 1.0 - (row + 1) * height + 0.1 * height
        axes = figure.add_axes((0.035 + 0.226 * place, bottom, 0.19, 0.74 * height),
                               gid=f"map-{measure}")
        image = _draw_panel(
            axes, grid, view_array, values[:, column], label=measure,
            predicted=None if rows is None else rows[column],
            max_latitude_deg=max_latitude_deg, limits=limits, view_set=chosen, fontsize=8.0,
        )
    colorbar = figure.colorbar(image, cax=figure.add_axes(
        (0.945, 0.1 * height, 0.012, 1.0 - 0.26 * height)))
    colorbar.set_label("quality (1 = best)", fontsize=8)
    colorbar.ax.tick_params(labelsize=7)
    if title:
        figure.suptitle(title, fontsize=10, y=1.0 - 0.01 / n_rows)
    return figure


def sphere_maps_file(
    quality_path: str | os.PathLike[str],
    output: str | os.PathLike[str],
    *,
    measures: Sequence[str] | None = None,
    predicted: ArrayLike | None = None,
    dpi: int = 100,
) -> Path:
    """Draw the maps of several measures a ``ViewQuality`` ``.npz`` records into one PNG.

    Parameters
    ----------
    quality_path : path-like
        ``vptool measures -o`` output, as
        :func:`~vptoolkit.pictures.sphere_map.sphere_map_file` reads it.
    output : path-like
        Target ``.png``.
    measures : sequence of str, optional
        The measures to draw, each one the file records (any case), in this
        order (default: every measure it records, in its order).
    predicted : (3,) array_like, optional
        A predicted direction to mark on every map.
    dpi : int
        Pixels per inch (default: 100: 1200 pixels wide, 340 high per row of four).

    Returns
    -------
    path : pathlib.Path
        The written PNG (:func:`sphere_maps`: four maps to a row).

    Raises
    ------
    InputError
        If the file cannot be read, lacks ``views`` or ``normalized``, or
        does not record one of ``measures``.
    """
    source = as_path(quality_path, "quality_path")
    views, normalized, names, name = read_quality_maps(source)
    try:
        columns = (list(range(len(names))) if measures is None
                   else [_column(measure, names) for measure in measures])
        figure = sphere_maps(views, normalized[:, columns],
                             measures=[names[c] for c in columns], predicted=predicted,
                             title=name)
    except InputError as err:
        raise InputError(f"{source.name}: {err}") from err
    return save_figure(figure, output, dpi=dpi)
