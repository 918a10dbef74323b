"""Viewpoint quality over the view sphere, drawn as a Mercator map.

The paper (Schelling et al. 2021, fig. 2) shows quality spheres as Mercator
projections; :func:`sphere_map` draws one measure, with the best sampled
view (star) and an optional predicted view (cross) marked. Columns of the
quality are named by ``measures`` (by default the paper's four,
``PAPER_MEASURES``); each map is titled with the registry's name for its measure
(:attr:`Measure.title <vptoolkit.measures.measure.Measure.title>`).
:func:`sphere_map_file` draws the ``.npz`` of ``vptool measures -o``,
whatever measures it records. :mod:`vptoolkit.pictures.sphere_panels` lays
the same map out once per measure on a grid of panels.

Map frame
    A view direction ``v = (x, y, z)`` (unit, from the model centre towards
    the camera) has

    * latitude ``phi = asin(y)``: ``+y`` is the top of the map (``phi = +90``
      degrees) and ``-y`` the bottom. These are the poles of the Fibonacci
      sphere (:func:`vptoolkit.sphere.fibonacci_sphere` is built along ``y``).
      Note that the cameras' image up is ``-y`` (:mod:`vptoolkit.camera`), so
      the top of the map holds the views from below the model's image-up.
    * longitude ``lambda = atan2(z, x)`` in (-180, 180] degrees: ``+x`` at
      0, ``+z`` at +90, ``-x`` at +/-180 (the left and right edges) and ``-z``
      at -90 degrees.

    Mercator maps ``(lambda, phi)`` to ``(lambda, ln tan(pi/4 + phi/2))``; the
    vertical axis is labelled in degrees of latitude. The poles lie at
    infinity, so the map stops at ``+/- max_latitude_deg`` (default 85
    degrees, where about 0.4 % of the sphere lies beyond each edge); markers
    of views beyond it are drawn on the edge.

Values
    Each map pixel shows the quality of the sampled view nearest to the
    pixel's direction (:func:`vptoolkit.sphere.nearest_view`), the authors'
    protocol for scoring an arbitrary direction. Colours are viridis; for
    normalised quality (values in [0, 1], 1 = best) the colour scale is fixed
    to [0, 1]. The best view is the sampled view of highest value.

matplotlib is imported inside the functions; nothing is drawn through
``pyplot``, so no display and no global figure state are involved.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import as_path, check_int
from vptoolkit.errors import InputError
from vptoolkit.files import atomic_write
from vptoolkit.measures.registry import PAPER_MEASURES, all_measures
from vptoolkit.optional import require
from vptoolkit.sphere import as_directions, nearest_view

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.image import AxesImage

__all__ = [
    "BEST_COLOR",
    "PREDICTED_COLOR",
    "VIEW_SET_COLOR",
    "view_coordinates",
    "mercator_y",
    "sphere_grid",
    "sphere_map",
    "save_figure",
    "sphere_map_file",
    "read_quality_maps",
]

BEST_COLOR = "#ff0000"
"""Face colour of the best-view star (no viridis colour is near pure red)."""

PREDICTED_COLOR = "#ffffff"
"""Face colour of the predicted-view cross (white, edged in black)."""

VIEW_SET_COLOR = "#ffa500"
"""Face colour of the numbered view-set circles (orange, edged in black)."""

_MAX_LATITUDE_DEG = 85.0
_GRID_WIDTH = 360  # map columns: one per degree of longitude
_QUERY_CHUNK = 4096  # grid directions per nearest-view query (a 4096 x n_views matrix)
_GRID_CACHE: dict[tuple[str, int, float], NDArray[np.int64]] = {}
_GRID_CACHE_SIZE = 8
_TITLE_CHARACTERS = 42  # characters of a measure's words that fit a panel's width at full size


# --------------------------------------------------------------------------- coordinates


def view_coordinates(directions: ArrayLike) -> NDArray[np.float64]:
    """Longitude and latitude of view directions, in degrees.

    Parameters
    ----------
    directions : (n, 3) or (3,) array_like
        Non-zero directions (normalised here).

    Returns
    -------
    coordinates : (n, 2) float64
        ``longitude = atan2(z, x)`` in (-180, 180] and ``latitude = asin(y)``
        in [-90, 90], both in degrees (see the module docstring).

    Examples
    --------
    >>> view_coordinates([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]).round(1)
    array([[90.,  0.],
           [ 0., 90.]])
    """
    unit = as_directions(directions, name="directions")
    longitude = np.degrees(np.arctan2(unit[:, 2], unit[:, 0]))
    latitude = np.degrees(np.arcsin(np.clip(unit[:, 1], -1.0, 1.0)))
    return np.stack([longitude, latitude], axis=1)


def mercator_y(latitude_deg: ArrayLike) -> NDArray[np.float64]:
    """Mercator ordinate ``ln tan(pi/4 + phi/2)`` of latitudes given in degrees.

    Parameters
    ----------
    latitude_deg : (n,) array_like
        Latitudes strictly between -90 and 90 degrees.

    Returns
    -------
    y : (n,) float64
        In radians of the equator's length (0 at the equator).
    """
    phi = np.radians(np.asarray(latitude_deg, dtype=np.float64))
    return np.asarray(np.log(np.tan(np.pi / 4.0 + phi / 2.0)), dtype=np.float64)


def _check_max_latitude(max_latitude_deg: float) -> float:
    value = float(max_latitude_deg)
    if not 0.0 < value < 90.0:
        raise InputError(f"max_latitude_deg: must lie in (0, 90) degrees, got {max_latitude_deg}")
    return value


def _grid_shape(width: int, max_latitude_deg: float) -> tuple[int, int]:
    """Rows and columns of a map with square pixels in Mercator units."""
    y_max = float(mercator_y([max_latitude_deg])[0])
    height = max(1, round(width * (2.0 * y_max) / (2.0 * math.pi)))
    return height, width


def sphere_grid(
    views: ArrayLike,
    *,
    width: int = _GRID_WIDTH,
    max_latitude_deg: float = _MAX_LATITUDE_DEG,
) -> NDArray[np.int64]:
    """Nearest sampled view of every pixel of a Mercator map.

    Pixel centres are spaced evenly in longitude and in Mercator ordinate;
    row 0 is the bottom of the map (latitude ``-max_latitude_deg``), as
    matplotlib draws it with ``origin="lower"``. Results are cached for the
    last few view sets, so maps of many models over the same views share one
    grid.

    Parameters
    ----------
    views : (n_views, 3) array_like
        The sampled view directions.
    width : int
        Map columns over 360 degrees of longitude (default: 360).
    max_latitude_deg : float
        Latitude of the top edge; the bottom edge is its negative (default: 85).

    Returns
    -------
    index : (height, width) int64
        Row of ``views`` nearest to each pixel's direction; ``height`` keeps
        the pixels square in Mercator units (359 rows for the defaults).
    """
    width = check_int(width, "width", minimum=2)
    max_latitude_deg = _check_max_latitude(max_latitude_deg)
    candidates = as_directions(views, name="views")
    key = (hashlib.sha1(candidates.tobytes()).hexdigest(), width, max_latitude_deg)
    cached = _GRID_CACHE.get(key)
    if cached is not None:
        return cached
    height, _ = _grid_shape(width, max_latitude_deg)
    y_max = float(mercator_y([max_latitude_deg])[0])
    longitude = np.radians(-180.0 + (np.arange(width) + 0.5) * 360.0 / width)
    ordinate = -y_max + (np.arange(height) + 0.5) * (2.0 * y_max / height)
    latitude = np.arctan(np.sinh(ordinate))  # inverse Mercator (the Gudermannian)
    lon, lat = np.meshgrid(longitude, latitude)  # (height, width)
    directions = np.stack(
        [np.cos(lat) * np.cos(lon), np.sin(lat), np.cos(lat) * np.sin(lon)], axis=-1
    ).reshape(-1, 3)
    index = np.zeros(len(directions), dtype=np.int64)
    for start in range(0, len(directions), _QUERY_CHUNK):
        stop = start + _QUERY_CHUNK
        index[start:stop] = nearest_view(directions[start:stop], candidates)
    grid = index.reshape(height, width)
    grid.flags.writeable = False
    if len(_GRID_CACHE) >= _GRID_CACHE_SIZE:
        _GRID_CACHE.pop(next(iter(_GRID_CACHE)))
    _GRID_CACHE[key] = grid
    return grid


# --------------------------------------------------------------------------- inputs


def _measure_names(measures: Sequence[str] | None) -> tuple[str, ...]:
    """The column names: as given (distinct), by default the paper's four."""
    if measures is None:
        return PAPER_MEASURES
    names = tuple(str(name) for name in measures)
    if not names or len(set(names)) != len(names):
        raise InputError(f"measures: expected distinct names, got {list(names)}")
    return names


def _quality_matrix(quality: ArrayLike, n_views: int, n_measures: int) -> NDArray[np.float64]:
    """``(n_views, k) float64`` from an (n_views, n_measures) array or one (n_views,) column."""
    try:
        values = np.array(quality, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f"quality: not a numeric array ({err})") from err
    if values.ndim == 1:
        values = values[:, None]
    if values.ndim != 2 or values.shape[0] != n_views or values.shape[1] not in (1, n_measures):
        raise InputError(f"quality: expected shape ({n_views}, {n_measures}) or ({n_views},), "
                         f"got {np.shape(quality)}")
    if np.isinf(values).any():
        raise InputError("quality: contains infinite values")
    return values


def _column(measure: str, names: Sequence[str]) -> int:
    """Column of ``measure`` (any case) among ``names``; one line naming what is drawn."""
    folded = [name.upper() for name in names]
    if not isinstance(measure, str) or measure.upper() not in folded:
        known = {name.upper() for name in all_measures()}
        problem = ("unknown measure" if not isinstance(measure, str)
                   or measure.upper() not in known else "no column for measure")
        raise InputError(f"measure: {problem} {measure!r}; the quality has "
                         f"{', '.join(names)}")
    return folded.index(measure.upper())


def _title(name: str) -> str:
    """The registry's words for a measure (``"viewpoint entropy"``); the name if unknown."""
    found = all_measures().get(name)
    return name if found is None else found.title


def _predicted_rows(predicted: ArrayLike | None, n_measures: int) -> NDArray[np.float64] | None:
    """``(n_measures, 3)`` predicted directions (NaN rows: none), from (3,) or (M, 3)."""
    if predicted is None:
        return None
    try:
        values = np.array(predicted, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f"predicted: not a numeric array ({err})") from err
    if values.shape == (3,):
        values = np.broadcast_to(values, (n_measures, 3)).copy()
    elif values.shape != (n_measures, 3):
        raise InputError(f"predicted: expected shape (3,) or ({n_measures}, 3), got {values.shape}")
    for row in values:
        if not np.isnan(row).all():
            as_directions(row, name="predicted")
    return values


# --------------------------------------------------------------------------- drawing


def _new_figure(size_inches: tuple[float, float]) -> Figure:
    """A pyplot-free figure (Agg canvas on save), or a MissingDependencyError."""
    require("matplotlib")
    from matplotlib.figure import Figure

    return Figure(figsize=size_inches, dpi=100)


def _draw_panel(
    axes: Axes,
    grid: NDArray[np.int64],
    views: NDArray[np.float64],
    values: NDArray[np.float64],
    *,
    label: str,
    predicted: NDArray[np.float64] | None,
    max_latitude_deg: float,
    limits: tuple[float, float],
    view_set: NDArray[np.float64] | None = None,
    fontsize: float = 9.0,
) -> AxesImage:
    """Draw one map on ``axes``; return the image artist (for a colour bar).

    The title is the measure's words from the registry, then ``label:
    best view i`` (and the prediction's value)."""
    y_max = float(mercator_y([max_latitude_deg])[0])
    shown = np.where(np.isnan(values), limits[0], values)
    image = axes.imshow(
        shown[grid], origin="lower", extent=(-180.0, 180.0, -y_max, y_max), cmap="viridis",
        vmin=limits[0], vmax=limits[1], interpolation="nearest", aspect="auto",
    )
    lat_ticks = [lat for lat in (-60.0, -30.0, 0.0, 30.0, 60.0) if abs(lat) < max_latitude_deg]
    axes.set_yticks(list(mercator_y(lat_ticks)))
    axes.set_yticklabels([f"{lat:+.0f}°" if lat else "0°" for lat in lat_ticks])
    axes.set_xticks([-180.0, -90.0, 0.0, 90.0, 180.0])
    axes.set_xticklabels(["-180°", "-90°", "0°", "+90°", "180°"])
    axes.set_xlim(-180.0, 180.0)
    axes.set_ylim(-y_max, y_max)
    axes.tick_params(labelsize=7)

    best = int(np.nanargmax(values)) if np.isfinite(values).any() else 0
    lon, lat = view_coordinates(views[best])[0]
    lat = float(np.clip(lat, -max_latitude_deg, max_latitude_deg))
    axes.plot([lon], mercator_y([lat]), linestyle="none", marker="*", markersize=15,
              markerfacecolor=BEST_COLOR, markeredgecolor="black", markeredgewidth=0.8,
              label=f"best: view {best}", gid="best", zorder=4)
    words = _title(label)
    title = f"{words}\n{label}: best view {best}"
    if predicted is not None and not np.isnan(predicted).all():
        nearest = int(nearest_view(predicted, views)[0])
        lon, lat = view_coordinates(predicted)[0]
        lat = float(np.clip(lat, -max_latitude_deg, max_latitude_deg))
        axes.plot([lon], mercator_y([lat]), linestyle="none", marker="X", markersize=11,
                  markerfacecolor=PREDICTED_COLOR, markeredgecolor="black", markeredgewidth=0.8,
                  label=f"predicted: {values[nearest]:.2f}", gid="predicted", zorder=3)
        title += f", predicted {values[nearest]:.2f}"
    if view_set is not None:
        for pick, (lon, lat) in enumerate(view_coordinates(view_set), start=1):
            lat = float(np.clip(lat, -max_latitude_deg, max_latitude_deg))
            axes.plot([lon], mercator_y([lat]), linestyle="none", marker="o", markersize=10,
                      markerfacecolor=VIEW_SET_COLOR, markeredgecolor="black",
                      markeredgewidth=0.8, gid=f"view-set-{pick}", zorder=5)
            axes.text(lon, float(mercator_y([lat])[0]), str(pick), ha="center", va="center",
                      fontsize=6, color="black", zorder=6)
    # a long name shrinks its title to the panel's width rather than run into the next
    axes.set_title(title, fontsize=fontsize * min(1.0, _TITLE_CHARACTERS / len(words)),
                   linespacing=1.1)
    return image


def _limits(values: NDArray[np.float64]) -> tuple[float, float]:
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return 0.0, 1.0
    low, high = float(finite.min()), float(finite.max())
    if low >= 0.0 and high <= 1.0:
        return 0.0, 1.0
    return (low, high) if high > low else (low - 0.5, high + 0.5)


def sphere_map(
    views: ArrayLike,
    quality: ArrayLike,
    *,
    measure: str | None = None,
    measures: Sequence[str] | None = None,
    predicted: ArrayLike | None = None,
    title: str | None = None,
    width: int = _GRID_WIDTH,
    max_latitude_deg: float = _MAX_LATITUDE_DEG,
) -> Figure:
    """One measure's quality over the view sphere as a Mercator map.

    Parameters
    ----------
    views : (n_views, 3) array_like
        Sampled view directions (e.g. ``ViewQuality.views``).
    quality : (n_views, M) or (n_views,) array_like
        Quality per view, higher is better: normalised quality, one column
        per name of ``measures`` (``ViewQuality.normalized``, a dataset
        item's ``quality``), of which column ``measure`` is drawn; or one
        column, drawn as it is with ``measure`` as its label. NaN is drawn
        as the lowest colour.
    measure : str, optional
        The measure to draw, one of ``measures`` in any case (default: the
        first of them; for the paper's four, VE).
    measures : sequence of str, optional
        The names of the columns of ``quality`` (default: the paper's four,
        ``PAPER_MEASURES``, which needs four columns or one).
    predicted : (3,) or (M, 3) array_like, optional
        A predicted direction, or one per measure in ``measures`` order (a
        NaN row draws no cross); marked with a white cross and its quality
        (that of the nearest sampled view) in the title.
    title : str, optional
        Figure title, e.g. the model name.
    width : int
        Map columns over 360 degrees of longitude (default: 360).
    max_latitude_deg : float
        Latitude of the map's top and (negated) bottom edge (default: 85).

    Returns
    -------
    figure : matplotlib.figure.Figure
        One map axes with gid ``"map"`` plus a colour bar; the best view is a
        red star (line gid ``"best"``), the prediction a white cross (gid
        ``"predicted"``). The map's title is the registry's words for the
        measure, then ``VE: best view i``. Save it with :func:`save_figure`.

    Raises
    ------
    InputError
        On a measure that is unknown or not among ``measures``, or wrong shapes.
    MissingDependencyError
        If matplotlib is not installed.
    """
    view_array = as_directions(views, name="views")
    names = _measure_names(measures)
    column = 0 if measure is None else _column(measure, names)
    values = _quality_matrix(quality, len(view_array), len(names))
    values = values[:, column] if values.shape[1] > 1 else values[:, 0]
    name = names[column]
    rows = _predicted_rows(predicted, len(names))
    grid = sphere_grid(view_array, width=width, max_latitude_deg=max_latitude_deg)
    figure = _new_figure((6.4, 5.4))
    axes = figure.add_axes((0.1, 0.1, 0.7, 0.78), gid="map")
    limits = _limits(values)
    image = _draw_panel(
        axes, grid, view_array, values, label=name,
        predicted=None if rows is None else rows[column],
        max_latitude_deg=_check_max_latitude(max_latitude_deg), limits=limits,
    )
    axes.set_xlabel("longitude atan2(z, x)", fontsize=8)
    axes.set_ylabel("latitude asin(y)", fontsize=8)
    colorbar = figure.colorbar(image, cax=figure.add_axes((0.84, 0.1, 0.03, 0.78)))
    colorbar.set_label(f"{name} quality (1 = best)" if limits == (0.0, 1.0) else name,
                       fontsize=8)
    colorbar.ax.tick_params(labelsize=7)
    if title:
        figure.suptitle(title, fontsize=10, y=0.99)
    return figure


# --------------------------------------------------------------------------- files


def save_figure(figure: Figure, path: str | os.PathLike[str], *, dpi: int = 100) -> Path:
    """Write a figure as PNG, atomically (a temporary sibling renamed into place).

    Parameters
    ----------
    figure : matplotlib.figure.Figure
        E.g. from :func:`sphere_map`.
    path : path-like
        Target file ending in ``.png``; its folder must exist.
    dpi : int
        Pixels per inch (default: 100, so a :func:`sphere_map` is 640 x 540).

    Returns
    -------
    path : pathlib.Path
    """
    target = as_path(path, "path")
    if target.suffix.lower() != ".png":
        raise InputError(f"{target.name}: output must end in .png")
    if not target.parent.is_dir():
        raise InputError(f"{target}: folder {target.parent} does not exist")
    dpi = check_int(dpi, "dpi", minimum=1)
    with atomic_write(target) as handle:
        figure.savefig(handle, format="png", dpi=dpi)
    return target


def read_quality_maps(source: Path) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                             tuple[str, ...], str]:
    """``views`` ``(n_views, 3)``, ``normalized`` ``(n_views, M)``, the ``M`` column names
    and the title (its ``name``, else the file's stem) of a ``ViewQuality`` .npz.

    A file without ``measures`` (written before measures were named) holds
    the paper's four; a file naming a measure the registry does not know is
    refused (``ViewQuality.save_npz`` writes registered names only). Raises
    InputError naming the file.
    """
    try:
        with open(source, "rb") as stream:
            is_zip = stream.read(4) == b"PK\x03\x04"
    except OSError as err:
        raise InputError(f"{source.name}: cannot be read ({err.strerror or err})") from err
    if not is_zip:  # np.load would call a text file "pickled data"
        raise InputError(f"{source.name}: not an .npz archive (expected the .npz of "
                         "vptool measures -o)")
    try:
        with np.load(source, allow_pickle=False) as archive:
            missing = [key for key in ("views", "normalized") if key not in archive.files]
            if missing:
                raise InputError(f"{source.name}: lacks {', '.join(missing)} "
                                 "(expected the .npz of vptool measures)")
            views = np.asarray(archive["views"], dtype=np.float64)
            normalized = np.asarray(archive["normalized"], dtype=np.float64)
            name = str(archive["name"]) if "name" in archive.files else source.stem
            names = (tuple(str(item) for item in np.atleast_1d(archive["measures"]))
                     if "measures" in archive.files else PAPER_MEASURES)
    except (OSError, ValueError, EOFError) as err:
        raise InputError(f"{source.name}: cannot be read as .npz ({err})") from err
    unknown = [name for name in names if name not in all_measures()]
    if unknown:
        raise InputError(f"{source.name}: unknown measure(s) "
                         f"{', '.join(repr(name) for name in unknown[:3])} (not in the registry; "
                         "expected the .npz of vptool measures)")
    if normalized.ndim != 2 or normalized.shape[1] != len(names):
        raise InputError(f"{source.name}: normalized has shape {normalized.shape}, expected "
                         f"(n_views, {len(names)}) for its measures {', '.join(names)}")
    return views, normalized, names, name


def sphere_map_file(
    quality_path: str | os.PathLike[str],
    output: str | os.PathLike[str],
    *,
    measure: str | None = None,
    predicted: ArrayLike | None = None,
    dpi: int = 100,
) -> Path:
    """Draw one measure's map of a ``.npz`` written by ``ViewQuality.save_npz`` into a PNG.

    Parameters
    ----------
    quality_path : path-like
        ``vptool measures -o`` output: ``views`` (n_views, 3),
        ``normalized`` (n_views, M) and ``measures`` (M names; the paper's
        four where absent), read with ``allow_pickle=False``; its ``name``
        (if present) becomes the title.
    output : path-like
        Target ``.png``.
    measure : str, optional
        Measure to draw, one the file records, in any case (default: the
        first it records; VE for the paper's four).
    predicted : (3,) or (M, 3) array_like, optional
        A predicted direction to mark.
    dpi : int
        Pixels per inch (default: 100, 640 x 540 pixels).

    Returns
    -------
    path : pathlib.Path
        The written PNG.

    Raises
    ------
    InputError
        If the file cannot be read, lacks ``views`` or ``normalized``, or
        does not record ``measure``, or that measure has no finite value.
    """
    source = as_path(quality_path, "quality_path")
    views, normalized, names, name = read_quality_maps(source)
    try:
        column = 0 if measure is None else _column(measure, names)
    except InputError as err:
        raise InputError(f"{source.name}: {err}") from err
    if not np.isfinite(normalized[:, column]).any():
        raise InputError(f"{source.name}: no finite {names[column]} value to draw (all NaN)")
    try:
        figure = sphere_map(views, normalized, measure=names[column], measures=names,
                            predicted=predicted, title=name)
    except InputError as err:  # "quality: ..." and "views: ..." name the file too
        raise InputError(f"{source.name}: {err}") from err
    return save_figure(figure, output, dpi=dpi)
