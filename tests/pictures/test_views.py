"""resolve_direction: a picture's direction from a vector, per-measure rows or a predictor."""

from __future__ import annotations

import numpy as np
import pytest

from fixtures.meshes import box_mesh
from vptoolkit.errors import InputError
from vptoolkit.pictures.views import resolve_direction


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
