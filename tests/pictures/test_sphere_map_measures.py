"""Quality maps of any measures: the panel grid adapts, titles come from the registry, and the
.npz of ``vptool measures`` is drawn as it records; the report of a three-measure dataset."""

from __future__ import annotations

import re

import numpy as np
import pytest

from fixtures.builds import build_samples
from fixtures.environment import require_package
from fixtures.pictures import read_png
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.errors import InputError
from vptoolkit.evaluate.baselines import oracle_directions
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.registry import all_measures, get_measure
from vptoolkit.predictions import write_predictions
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere

THREE = ("NVT", "SL", "MD")


def _best_marker(axes) -> np.ndarray:
    (line,) = [line for line in axes.lines if line.get_gid() == "best"]
    return np.array([line.get_xdata()[0], line.get_ydata()[0]])


@pytest.fixture(scope="module")
def measured(tmp_path_factory: pytest.TempPathFactory):
    """The mug's NVT, SL and MD over 80 views at 48 px, and their .npz."""
    quality = compute_view_quality(load_mesh(sample_path("mug.obj")),
                                   MeasureSettings(views=80, resolution=48), measures=THREE)
    return quality, quality.save_npz(tmp_path_factory.mktemp("measured") / "mug.npz")


def test_three_measures_make_one_row_titled_by_the_registry(matplotlib_available, measured):
    from vptoolkit.pictures.sphere_map import mercator_y, sphere_maps, view_coordinates

    quality, _ = measured
    figure = sphere_maps(quality.views, quality.normalized, measures=quality.measures,
                         title="mug")
    maps = [axes for axes in figure.axes if (axes.get_gid() or "").startswith("map-")]
    assert [axes.get_gid() for axes in maps] == [f"map-{name}" for name in THREE]
    assert tuple(figure.get_size_inches()) == (12.0, 3.4)
    for column, (axes, name) in enumerate(zip(maps, THREE)):
        best = int(quality.best_index[column])
        title = axes.get_title()
        assert title.split("\n") == [get_measure(name).title, f"{name}: best view {best}"]
        lon, lat = view_coordinates(quality.views[best])[0]
        np.testing.assert_allclose(_best_marker(axes), [lon, mercator_y([lat])[0]])


def test_every_registered_measure_fills_a_grid_of_four_to_a_row(matplotlib_available,
                                                                tmp_path):
    from vptoolkit.pictures.sphere_map import save_figure, sphere_maps

    names = tuple(all_measures())
    views = fibonacci_sphere(100)
    quality = np.random.default_rng(0).random((100, len(names)))
    figure = sphere_maps(views, quality, measures=names)
    rows = -(-len(names) // 4)
    assert tuple(figure.get_size_inches()) == (12.0, 3.4 * rows)
    maps = {axes.get_gid(): axes for axes in figure.axes if (axes.get_gid() or "").startswith(
        "map-")}
    assert list(maps) == [f"map-{name}" for name in names]
    lefts = [round(axes.get_position().x0, 3) for axes in maps.values()]
    assert lefts[:4] == lefts[4:8] and len(set(lefts)) == 4  # the grid's columns
    tops = sorted({round(axes.get_position().y1, 3) for axes in maps.values()}, reverse=True)
    assert len(tops) == rows
    assert maps["map-EVMI"].get_title().startswith(get_measure("EVMI").title)
    image = read_png(save_figure(figure, tmp_path / "all.png", dpi=50))
    assert image.shape[:2] == (round(50 * 3.4 * rows), 600)
    with pytest.raises(InputError, match=r"quality: expected shape \(100, 22\)"):
        sphere_maps(views, quality[:, :3], measures=names)
    with pytest.raises(InputError, match=r"quality: expected shape \(100, 4\)"):
        sphere_maps(views, quality[:, :3])  # no names: the paper's four


def test_a_single_map_of_a_named_column(matplotlib_available, measured):
    from vptoolkit.pictures.sphere_map import sphere_map

    quality, _ = measured
    figure = sphere_map(quality.views, quality.normalized, measure="sl",
                        measures=quality.measures)
    best = int(quality.best_index[1])
    assert figure.axes[0].get_title() == f"silhouette length\nSL: best view {best}"
    first = sphere_map(quality.views, quality.normalized, measures=quality.measures)
    assert first.axes[0].get_title().endswith(f"NVT: best view {quality.best_index[0]}")
    with pytest.raises(InputError, match="measure: no column for measure 'VE'; the quality has "
                                         "NVT, SL, MD"):
        sphere_map(quality.views, quality.normalized, measure="VE", measures=quality.measures)


def test_the_measures_npz_is_drawn_as_it_records(matplotlib_available, measured, tmp_path):
    from vptoolkit.pictures.sphere_map import sphere_map_file, sphere_maps_file

    _, path = measured
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
             measures=np.array(THREE))
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
