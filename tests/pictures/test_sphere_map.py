"""Mercator quality maps of the view sphere, of the paper's four and of any other measures."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fixtures.builds import build_samples
from fixtures.environment import require_package
from fixtures.pictures import MUG_MEASURES, preferred_directions, read_png, smooth_quality
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.errors import InputError
from vptoolkit.evaluate.baselines import oracle_directions
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.predictions import write_predictions
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


def test_sphere_map_file_reads_the_measures_npz(matplotlib_available, tmp_path: Path, cube):
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


# --- maps of any measures -----------------------------------------------------------------


def test_a_single_map_of_a_named_column(matplotlib_available, measured_mug):
    from vptoolkit.pictures.sphere_map import sphere_map

    quality, _ = measured_mug
    figure = sphere_map(quality.views, quality.normalized, measure="sl",
                        measures=quality.measures)
    best = int(quality.best_index[1])
    assert figure.axes[0].get_title() == f"silhouette length\nSL: best view {best}"
    first = sphere_map(quality.views, quality.normalized, measures=quality.measures)
    assert first.axes[0].get_title().endswith(f"NVT: best view {quality.best_index[0]}")
    with pytest.raises(InputError, match="measure: no column for measure 'VE'; the quality has "
                                         "NVT, SL, MD"):
        sphere_map(quality.views, quality.normalized, measure="VE", measures=quality.measures)


def test_the_measures_npz_is_drawn_as_it_records(matplotlib_available, measured_mug, tmp_path):
    from vptoolkit.pictures.sphere_map import sphere_map_file
    from vptoolkit.pictures.sphere_panels import sphere_maps_file

    _, path = measured_mug
    assert read_png(sphere_maps_file(path, tmp_path / "all.png")).shape[:2] == (340, 1200)
    assert read_png(sphere_maps_file(path, tmp_path / "two.png", measures=["md", "NVT"],
                                     dpi=50)).shape[:2] == (170, 600)
    assert read_png(sphere_map_file(path, tmp_path / "md.png", measure="MD")).shape[:2] == (
        540, 640)
    with pytest.raises(InputError, match="^mug.npz: measure: no column for measure 'VKL'"):
        sphere_map_file(path, tmp_path / "vkl.png", measure="VKL")
    with pytest.raises(InputError, match="^mug.npz: measure: unknown measure 'XX'"):
        sphere_maps_file(path, tmp_path / "xx.png", measures=["XX"])
    older = tmp_path / "older.npz"  # written before the measures were named: the paper's four
    np.savez(older, views=fibonacci_sphere(30), normalized=np.random.default_rng(1).random(
        (30, 4)))
    assert read_png(sphere_map_file(older, tmp_path / "older.png", measure="VKL")).shape[:2] \
        == (540, 640)
    np.savez(older, views=fibonacci_sphere(30), normalized=np.ones((30, 2)),
             measures=np.array(MUG_MEASURES))
    with pytest.raises(InputError, match=r"older.npz: normalized has shape \(30, 2\)"):
        sphere_maps_file(older, tmp_path / "bad.png")


def test_the_report_of_a_three_measure_dataset(matplotlib_available, tmp_path):
    require_package("zarr")
    from vptoolkit.data import open_dataset
    from vptoolkit.pictures.report import write_report

    options = BuildOptions(MeasureSettings(views=40, resolution=48), measures="VE,NVT,SL",
                           n_points=200, clean=False)
    built = build_samples(tmp_path, ("mug.obj", "teapot.stl"), category="things",
                          options=options)
    with open_dataset(built) as dataset:
        oracle = oracle_directions(dataset)[:, [2, 1]]
        predictions = write_predictions(tmp_path / "p.npz", dataset.names, oracle,
                                        measures=("SL", "NVT"))
        index = write_report(dataset, tmp_path / "report", predictions=predictions,
                             thumbnails=False, view_set=None)
    page = index.read_text()
    assert re.findall(r"<th>(\w+) %</th>", page) == ["NVT", "SL"]
    assert page.count('width="960" height="272"') == 2
    assert page.count("not predicted") == 2  # VE of each model
    assert page.count('<span class="score">100.0 %</span>') == 4
    maps = sorted((tmp_path / "report" / "maps").glob("*.png"))
    assert len(maps) == 2 and read_png(maps[0]).shape[:2] == (272, 960)
