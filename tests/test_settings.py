"""MeasureSettings: defaults from the conventions, one-line checks, a JSON round trip."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vptoolkit.camera import Camera
from vptoolkit.conventions import N_VIEWS, RESOLUTION
from vptoolkit.errors import InputError
from vptoolkit.settings import MAX_RESOLUTION, MeasureSettings
from vptoolkit.sphere import fibonacci_sphere


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
