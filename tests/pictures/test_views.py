"""resolve_direction: a picture's direction from a vector, per-measure rows or a predictor;
render_best of any registered measure."""

from __future__ import annotations

import numpy as np
import pytest

from fixtures.meshes import box_mesh
from vptoolkit.errors import InputError
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.pictures.views import render_best, resolve_direction
from vptoolkit.settings import MeasureSettings


@pytest.mark.parametrize(
    ("source", "measure", "expected"),
    [
        ([0.0, 0.0, 2.0], "VE", [0.0, 0.0, 1.0]),
        (np.eye(4, 3) + [0.0, 0.0, 1e-9], "vr", [0.0, 1.0, 0.0]),
        (lambda mesh: [[3.0, 0.0, 0.0]], "VMI", [1.0, 0.0, 0.0]),
    ],
    ids=["one-direction", "per-measure", "callable"],
)
def test_resolve_direction(source, measure, expected):
    direction = resolve_direction(box_mesh(), source, measure=measure)
    np.testing.assert_allclose(direction, expected, atol=1e-8)


@pytest.mark.parametrize(
    ("source", "measure", "message"),
    [
        ([0.0, 0.0, 0.0], "VE", "zero-length"),
        (np.zeros((2, 3)), "VE", "expected a"),
        ([1.0, 0.0, 0.0], "VX", "unknown measure"),
        (lambda mesh: "up", "VE", "not numeric"),
    ],
    ids=["zero", "two-rows", "measure", "text"],
)
def test_resolve_direction_rejects(source, measure, message):
    with pytest.raises(InputError, match=message):
        resolve_direction(box_mesh(), source, measure=measure)


class _Predictor:
    """A source that names the measures of its rows, as a MeshPredictor does."""

    measures = ("NVT", "SL")

    def __call__(self, mesh):
        return [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]


def test_rows_follow_the_measures_a_source_names():
    np.testing.assert_allclose(resolve_direction(box_mesh(), _Predictor(), measure="sl"),
                               [1.0, 0.0, 0.0])
    with pytest.raises(InputError, match=r"^measure: VE is not among the measures here "
                                         r"\(NVT, SL\)$"):
        resolve_direction(box_mesh(), _Predictor(), measure="VE")


def test_render_best_draws_the_best_view_of_any_registered_measure():
    mesh = box_mesh((1.0, 2.0, 3.0))
    settings = MeasureSettings(views=30, resolution=32)
    view = render_best(mesh, measure="nvt", settings=settings)
    quality = compute_view_quality(mesh, settings, measures="NVT")
    np.testing.assert_array_equal(view.direction, quality.best_views[0])
    assert view.label.startswith("best NVT (view ")
    with pytest.raises(InputError, match="^measure: SL is not among the measures here"):
        render_best(mesh, measure="SL", quality=quality)

