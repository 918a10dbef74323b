"""Every measure's map on one figure: the panel grid adapts to the measures, four to a row,
each panel titled by the registry."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fixtures.pictures import MUG_MEASURES, preferred_directions, read_png, smooth_quality
from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES, all_measures, get_measure
from vptoolkit.sphere import fibonacci_sphere

N_VIEWS = 200


def _best_marker(axes) -> np.ndarray:
    (line,) = [line for line in axes.lines if line.get_gid() == "best"]
    return np.array([line.get_xdata()[0], line.get_ydata()[0]])


def test_sphere_maps_draws_four_panels(matplotlib_available, tmp_path: Path):
    from vptoolkit.pictures.sphere_map import save_figure
    from vptoolkit.pictures.sphere_panels import sphere_maps

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


def test_three_measures_make_one_row_titled_by_the_registry(matplotlib_available, measured_mug):
    from vptoolkit.pictures.sphere_map import mercator_y, view_coordinates
    from vptoolkit.pictures.sphere_panels import sphere_maps

    quality, _ = measured_mug
    figure = sphere_maps(quality.views, quality.normalized, measures=quality.measures,
                         title="mug")
    maps = [axes for axes in figure.axes if (axes.get_gid() or "").startswith("map-")]
    assert [axes.get_gid() for axes in maps] == [f"map-{name}" for name in MUG_MEASURES]
    assert tuple(figure.get_size_inches()) == (12.0, 3.4)
    for column, (axes, name) in enumerate(zip(maps, MUG_MEASURES)):
        best = int(quality.best_index[column])
        title = axes.get_title()
        assert title.split("\n") == [get_measure(name).title, f"{name}: best view {best}"]
        lon, lat = view_coordinates(quality.views[best])[0]
        np.testing.assert_allclose(_best_marker(axes), [lon, mercator_y([lat])[0]])


def test_every_registered_measure_fills_a_grid_of_four_to_a_row(matplotlib_available,
                                                                tmp_path):
    from vptoolkit.pictures.sphere_map import save_figure
    from vptoolkit.pictures.sphere_panels import sphere_maps

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
