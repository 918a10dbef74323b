"""The elevation band of a search: every direction drawn, and the answers, lie in it; without
a band the search draws what it always drew."""

from __future__ import annotations

import numpy as np
import pytest

from fixtures.paths import ASSETS
from vptoolkit.best_view.search import SearchSettings, search_best_views
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.sphere import band_directions, elevation_deg, into_band

Z_UP = (0.0, 0.0, 1.0)
TOLERANCE = 1e-9  # degrees


@pytest.fixture(scope="module")
def stop_sign():
    return load_mesh(ASSETS / "gazebo" / "stop_sign.ply")


def _in_band(directions, low, high):
    angles = elevation_deg(directions, Z_UP)
    return bool(((angles >= low - TOLERANCE) & (angles <= high + TOLERANCE)).all())


@pytest.mark.parametrize("budget", [8, 64])
def test_every_drawn_direction_and_answer_lies_in_the_band(stop_sign, budget):
    """z-up stop sign, band 0..60 degrees: the coarse band, a prior with candidates below and
    above the band, and every refinement ring stay in it (flat and staged budgets)."""
    prior = [[0, 0, -1], [0, 0, 1], [0.2, -1, -0.9], [0, -1, 0]]
    settings = SearchSettings(budget=budget, resolution=48, up=Z_UP, elevation=(0, 60))
    found = search_best_views(stop_sign, settings, prior=prior)
    assert found.drawn.shape == (found.n_views, 3) == (budget, 3)
    assert _in_band(found.drawn, 0.0, 60.0)
    assert _in_band(found.directions, 0.0, 60.0)
    if budget >= 16:
        assert [stage.name for stage in found.stages][-1] == "refine"
    # the exported pose keeps the up axis at the top of the image (OpenCV: -y column)
    assert found.camera_pose("VE")[2, 1] < 0


def test_the_full_sphere_records_what_it_drew_and_reaches_below_the_horizon(stop_sign):
    found = search_best_views(stop_sign, SearchSettings(budget=32, resolution=48, up=Z_UP))
    assert found.drawn.shape == (32, 3)
    assert elevation_deg(found.drawn, Z_UP).min() < -30.0  # no band: below the horizon too
    first = found.stages[0].n_views
    np.testing.assert_allclose(np.linalg.norm(found.drawn[:first], axis=1), 1.0)


def test_band_directions_cover_the_band_evenly():
    directions = band_directions(400, Z_UP, (0.0, 60.0))
    sines = directions[:, 2]
    assert _in_band(directions, 0.0, 60.0)
    # equal areas: the sine of the elevation is uniform over [0, sin 60]
    np.testing.assert_allclose(np.sort(sines), (np.arange(400) + 0.5) / 400 * np.sin(np.pi / 3))
    assert np.abs(directions[:, :2].mean(axis=0)).max() < 0.02  # all around the axis


def test_into_band_keeps_the_azimuth_and_leaves_the_band_alone():
    inside = np.array([[1.0, 0.0, 0.5]]) / np.sqrt(1.25)
    np.testing.assert_array_equal(into_band(inside, Z_UP, (0, 60)), inside)
    below = np.array([[0.0, 1.0, -1.0]]) / np.sqrt(2.0)
    np.testing.assert_allclose(into_band(below, Z_UP, (0, 60)), [[0.0, 1.0, 0.0]], atol=1e-15)
    pole = into_band([[0.0, 0.0, 1.0]], Z_UP, (0, 60))
    assert elevation_deg(pole, Z_UP)[0] == pytest.approx(60.0)


@pytest.mark.parametrize(("elevation", "up"), [((60, 0), Z_UP), ((-91, 0), Z_UP),
                                               ((0, 60, 90), Z_UP), ((0, 60), (0, 0, 0)),
                                               ("0,60", Z_UP)])
def test_bad_bands_and_axes_are_one_line(elevation, up):
    with pytest.raises(InputError, match="^(elevation|up): expected"):
        SearchSettings(elevation=elevation, up=up)


def test_the_record_names_the_band_and_axis_only_when_given():
    assert "elevation" not in SearchSettings().to_dict() and "up" not in SearchSettings().to_dict()
    record = SearchSettings(up=(0, 0, 2), elevation=(0, 60)).to_dict()
    assert record["up"] == [0.0, 0.0, 1.0] and record["elevation"] == [0.0, 60.0]
