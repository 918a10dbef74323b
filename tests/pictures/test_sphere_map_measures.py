"""Quality maps of any measures: one named column, the .npz of ``vptool measures`` drawn as
it records; the report of a three-measure dataset."""

from __future__ import annotations

import re

import numpy as np
import pytest

from fixtures.builds import build_samples
from fixtures.environment import require_package
from fixtures.pictures import MUG_MEASURES, read_png
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.errors import InputError
from vptoolkit.evaluate.baselines import oracle_directions
from vptoolkit.predictions import write_predictions
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere


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
