"""MeasureSettings: defaults from the conventions, one-line checks, a JSON round trip."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from vptoolkit.camera import Camera
from vptoolkit.conventions import N_VIEWS, RESOLUTION
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.mesh import Mesh
from vptoolkit.pictures.contact_sheet import view_set_sheet
from vptoolkit.pictures.thumbnails import render_thumbnails
from vptoolkit.pictures.views import render_best
from vptoolkit.samples import sample_path
from vptoolkit.settings import MAX_RESOLUTION, MeasureSettings, check_settings
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.view_sets.search import best_view_set, measure_view_set
from vptoolkit.view_sets.visibility import FaceVisibility
from vptoolkit.visibility import (
    face_id_images,
    face_pixel_counts,
    face_pixel_totals,
    iter_view_histograms,
)


def test_defaults_come_from_the_conventions():
    settings = MeasureSettings()
    assert (settings.views, settings.resolution) == (N_VIEWS, RESOLUTION)
    assert settings.camera == Camera()
    assert settings.backend == "raster"


def test_numpy_integers_become_plain_ints():
    settings = MeasureSettings(views=np.int64(12), resolution=np.int32(64))
    assert type(settings.views) is int and type(settings.resolution) is int
    assert settings == MeasureSettings(views=12, resolution=64)


@pytest.mark.parametrize(("fields", "message"), [
    ({"views": 0}, "views: must be at least 1, got 0"),
    ({"views": 2.5}, "views: expected an integer, got 2.5"),
    ({"views": True}, "views: expected an integer, got True"),
    ({"resolution": 0}, "resolution: must be at least 1, got 0"),
    ({"resolution": MAX_RESOLUTION + 1},
     f"resolution: must be at most {MAX_RESOLUTION}, got {MAX_RESOLUTION + 1}"),
    ({"backend": "opengl"}, "backend: must be one of raster, raycast, got 'opengl'"),
    ({"camera": "perspective"}, "camera: expected a Camera, got str"),
])
def test_bad_fields_raise_one_line_input_errors(fields, message):
    with pytest.raises(InputError) as info:
        MeasureSettings(**fields)
    assert str(info.value) == message


def test_settings_are_frozen_and_hashable():
    settings = MeasureSettings(views=10)
    with pytest.raises(AttributeError):
        settings.views = 20  # type: ignore[misc]
    assert len({settings, MeasureSettings(views=10)}) == 1


def test_a_json_record_gives_back_equal_settings():
    settings = MeasureSettings(views=50, resolution=128, camera=Camera(fov_deg=60.0),
                               backend="raycast")
    record = json.loads(json.dumps(settings.to_dict()))
    assert record["views"] == 50 and record["camera"]["fov_deg"] == 60.0
    assert MeasureSettings.from_dict(record) == settings


def test_a_record_with_missing_or_unknown_keys_is_refused():
    record = MeasureSettings().to_dict()
    del record["backend"]
    record["n_views"] = 1000
    with pytest.raises(InputError, match=r"^measure settings: missing backend; unknown n_views$"):
        MeasureSettings.from_dict(record)
    record = {**MeasureSettings().to_dict(), "views": -3}
    with pytest.raises(InputError, match="^views: must be at least 1, got -3$"):
        MeasureSettings.from_dict(record)


def test_directions_are_the_fibonacci_sphere():
    np.testing.assert_array_equal(MeasureSettings(views=7).directions(), fibonacci_sphere(7))


def test_check_settings_passes_settings_and_names_anything_else():
    settings = MeasureSettings(views=10)
    assert check_settings(settings) is settings
    with pytest.raises(InputError, match=r"^measure: expected MeasureSettings, got dict$"):
        check_settings({"views": 10}, "measure")
    with pytest.raises(InputError, match=r"^settings: expected MeasureSettings, got bool$"):
        check_settings(True)


# Every public function that takes a MeasureSettings, called with the old positional
# number of views in its place.
ENTRY_POINTS: dict[str, Callable[[Mesh, Any, Path], object]] = {
    "compute_view_quality": lambda mesh, bad, _: compute_view_quality(mesh, bad),
    "iter_view_histograms": lambda mesh, bad, _: list(iter_view_histograms(mesh, bad)),
    "face_id_images": lambda mesh, bad, _: face_id_images(mesh, bad),
    "face_pixel_counts": lambda mesh, bad, _: face_pixel_counts(mesh, bad),
    "face_pixel_totals": lambda mesh, bad, _: face_pixel_totals(mesh, bad),
    "FaceVisibility.from_mesh": lambda mesh, bad, _: FaceVisibility.from_mesh(mesh, bad),
    "best_view_set": lambda mesh, bad, _: best_view_set(mesh, 2, settings=bad),
    "measure_view_set": lambda mesh, bad, _: measure_view_set(mesh, 2, settings=bad),
    "view_set_sheet": lambda mesh, bad, _: view_set_sheet(mesh, 2, settings=bad),
    "render_best": lambda mesh, bad, _: render_best(mesh, settings=bad),
    "render_thumbnails": lambda _, bad, tmp: render_thumbnails(
        sample_path("torus.STL"), tmp / "out", settings=bad),
}


@pytest.mark.parametrize("entry", sorted(ENTRY_POINTS))
def test_every_entry_point_refuses_a_number_of_views_in_one_line(entry, tmp_path):
    mesh = load_mesh(sample_path("torus.STL"))
    with pytest.raises(InputError) as info:
        ENTRY_POINTS[entry](mesh, 100, tmp_path)
    assert str(info.value) == ("settings: expected MeasureSettings, got int 100 "
                               "(pass MeasureSettings(views=100))")
    assert not (tmp_path / "out").exists()
