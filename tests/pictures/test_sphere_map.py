"""Mercator quality maps of the view sphere."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fixtures.pictures import preferred_directions, read_png, smooth_quality
from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere, nearest_view

N_VIEWS = 200

BEST_RED_MIN, BEST_GREEN_MAX = 200, 60  # the star's pure red; viridis has none
VIRIDIS_TOP = np.array([253, 231, 37])  # the colour of quality 1


def figure_pixels(figure: Any) -> np.ndarray:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()


def display_to_pixel(figure: Any, axes: Any, lon: float, lat: float) -> np.ndarray:
    """Array (column, row) of a map point given in degrees."""
    from vptoolkit.pictures.sphere_map import mercator_y

    x, y = axes.transData.transform((lon, float(mercator_y([lat])[0])))
    return np.array([x, figure.bbox.height - y])


def axes_region(figure: Any, axes: Any, pixels: np.ndarray) -> tuple[slice, slice]:
    box = axes.get_window_extent()
    height = pixels.shape[0]
    return (slice(int(height - box.y1) + 2, int(height - box.y0) - 2),
            slice(int(box.x0) + 2, int(box.x1) - 2))


def centroid(mask: np.ndarray) -> np.ndarray:
    rows, columns = np.nonzero(mask)
    assert rows.size, "no such pixels"
    return np.array([columns.mean(), rows.mean()])


def test_view_coordinates_frame():
    from vptoolkit.pictures.sphere_map import view_coordinates

    directions = [[1, 0, 0], [0, 0, 1], [0, 0, -1], [-1, 0, 1e-12], [0, 1, 0], [0, -2, 0]]
    np.testing.assert_allclose(
        view_coordinates(directions),
        [[0, 0], [90, 0], [-90, 0], [180, 0], [0, 90], [0, -90]], atol=1e-6,
    )


def test_sphere_grid_holds_the_nearest_view_of_each_pixel():
    from vptoolkit.pictures.sphere_map import mercator_y, sphere_grid

    views = fibonacci_sphere(300)
    grid = sphere_grid(views, width=120, max_latitude_deg=80.0)
    y_max = float(mercator_y([80.0])[0])
    height = grid.shape[0]
    assert grid.shape == (round(120 * y_max / np.pi), 120) and grid.dtype == np.int64
    assert sphere_grid(views, width=120, max_latitude_deg=80.0) is grid  # cached
    for row, column in [(0, 0), (height // 2, 37), (height - 1, 119), (5, 90)]:
        lon = np.radians(-180.0 + (column + 0.5) * 3.0)
        lat = np.arctan(np.sinh(-y_max + (row + 0.5) * 2.0 * y_max / height))
        direction = [np.cos(lat) * np.cos(lon), np.sin(lat), np.cos(lat) * np.sin(lon)]
        assert grid[row, column] == nearest_view(direction, views)[0]


@pytest.mark.parametrize("measure", PAPER_MEASURES)
def test_the_marked_maximum_sits_where_the_quality_array_says(matplotlib_available, measure):
    from vptoolkit.pictures.sphere_map import sphere_map, view_coordinates

    views = fibonacci_sphere(1000)
    quality = smooth_quality(views, preferred_directions(f"map-{measure}"))
    figure = sphere_map(views, quality, measure=measure)
    pixels = figure_pixels(figure)
    axes = next(a for a in figure.axes if a.get_gid() == "map")
    region = axes_region(figure, axes, pixels)
    inside = pixels[region]
    column = PAPER_MEASURES.index(measure)
    best = int(np.argmax(quality[:, column]))
    lon, lat = view_coordinates(views[best])[0]
    expected = display_to_pixel(figure, axes, lon, lat)
    offset = np.array([region[1].start, region[0].start])
    red = (inside[:, :, 0] >= BEST_RED_MIN) & (inside[:, :, 1] <= BEST_GREEN_MAX) & (
        inside[:, :, 2] <= BEST_GREEN_MAX)
    assert np.linalg.norm(centroid(red) + offset - expected) < 2.5
    # The brightest (quality 1) colour of the map lies under the star too.
    top = np.abs(inside.astype(int) - VIRIDIS_TOP).sum(axis=2) < 30
    assert np.linalg.norm(centroid(top) + offset - expected) < 12.0
    assert f"{measure}: best view {best}" in axes.get_title()


def test_the_predicted_view_is_crossed_with_its_score(matplotlib_available):
    from vptoolkit.pictures.sphere_map import sphere_map, view_coordinates

    views = fibonacci_sphere(1000)
    quality = smooth_quality(views, preferred_directions("predicted"))
    predicted = np.array([0.3, -0.4, 0.8])
    figure = sphere_map(views, quality, measure="VR", predicted=predicted)
    pixels = figure_pixels(figure)
    axes = figure.axes[0]
    region = axes_region(figure, axes, pixels)
    inside = pixels[region]
    white = (inside >= 245).all(axis=2)
    lon, lat = view_coordinates(predicted)[0]
    expected = display_to_pixel(figure, axes, lon, lat)
    offset = np.array([region[1].start, region[0].start])
    assert np.linalg.norm(centroid(white) + offset - expected) < 2.5
    score = quality[nearest_view(predicted, views)[0], 1]
    assert axes.get_title().endswith(f"predicted {score:.2f}")


def test_sphere_maps_draws_four_panels(matplotlib_available, tmp_path: Path):
    from vptoolkit.pictures.sphere_map import save_figure, sphere_maps

    views = fibonacci_sphere(N_VIEWS)
    quality = smooth_quality(views, preferred_directions("four"))
    predicted = np.full((4, 3), np.nan)
    predicted[2] = [0, 0, 1]
    figure = sphere_maps(views, quality, predicted=predicted, title="four")
    gids = [a.get_gid() for a in figure.axes]
    assert gids[:4] == [f"map-{m}" for m in PAPER_MEASURES]
    crosses = [any(line.get_gid() == "predicted" for line in a.lines) for a in figure.axes[:4]]
    assert crosses == [False, False, True, False]
    image = read_png(save_figure(figure, tmp_path / "maps.png"))
    assert image.shape[:2] == (340, 1200)


def test_sphere_map_file_reads_the_measures_npz(matplotlib_available, tmp_path: Path, cube):
    from vptoolkit.measures.quality import compute_view_quality
    from vptoolkit.pictures.sphere_map import sphere_map_file

    quality_path = compute_view_quality(cube, MeasureSettings(views=100, resolution=32)).save_npz(
        tmp_path / "cube.npz")
    written = sphere_map_file(quality_path, tmp_path / "cube.png", measure="vkl")
    assert read_png(written).shape[:2] == (540, 640)
    np.savez(tmp_path / "other.npz", views=fibonacci_sphere(10))
    with pytest.raises(InputError, match="other.npz: lacks normalized"):
        sphere_map_file(tmp_path / "other.npz", tmp_path / "other.png")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"measure": "VX"}, "unknown measure"),
        ({"quality": np.zeros((10, 4))}, r"quality: expected shape \(200, 4\)"),
        ({"predicted": np.zeros((2, 3))}, "predicted: expected shape"),
        ({"predicted": [0.0, 0.0, 0.0]}, "zero-length"),
        ({"max_latitude_deg": 90.0}, "max_latitude_deg"),
    ],
    ids=["measure", "quality-shape", "predicted-shape", "predicted-zero", "latitude"],
)
def test_sphere_map_rejects_bad_arguments(matplotlib_available, kwargs, message):
    from vptoolkit.pictures.sphere_map import sphere_map

    views = fibonacci_sphere(N_VIEWS)
    arguments = {"quality": np.ones((N_VIEWS, 4)), **kwargs}
    with pytest.raises(InputError, match=message):
        sphere_map(views, **arguments)
