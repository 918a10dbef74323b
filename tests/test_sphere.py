import math

import numpy as np
import pytest

from vptoolkit.errors import InputError
from vptoolkit.sphere import (
    angle_between_deg,
    as_directions,
    coarse_directions,
    fibonacci_sphere,
    nearest_view,
)


def test_fibonacci_matches_the_authors_formula_point_by_point():
    n = 1000
    views = fibonacci_sphere(n)
    offset, increment = 2.0 / n, math.pi * (3.0 - math.sqrt(5.0))
    for i in (0, 1, 499, 998, 999):
        y = i * offset - 1 + offset / 2
        r = math.sqrt(1 - y * y)
        phi = ((i + 1) % n) * increment
        np.testing.assert_allclose(views[i], [math.cos(phi) * r, y, math.sin(phi) * r], atol=1e-15)


def test_fibonacci_is_unit_and_nearly_uniform():
    views = fibonacci_sphere(1000)
    assert views.shape == (1000, 3) and views.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(views, axis=1), 1.0, atol=1e-12)
    assert abs(views.mean(axis=0)).max() < 0.01
    # every point's nearest neighbour lies between 5 and 8 degrees away
    cosines = views @ views.T
    np.fill_diagonal(cosines, -1.0)
    nearest = np.degrees(np.arccos(cosines.max(axis=1)))
    assert 4.0 < nearest.min() and nearest.max() < 8.0


@pytest.mark.parametrize("bad", [0, -3, 2.5, True, "10"], ids=repr)
def test_fibonacci_rejects_bad_counts(bad):
    with pytest.raises(InputError, match="^n: "):
        fibonacci_sphere(bad)


def test_nearest_view_finds_each_view_itself_and_ignores_length():
    views = fibonacci_sphere(1000)
    np.testing.assert_array_equal(nearest_view(views * 7.5, views), np.arange(1000))
    assert nearest_view([0, 1e-3, 1], views).shape == (1,)


def test_as_directions_rejects_zero_nan_and_shapes():
    with pytest.raises(InputError, match="zero-length"):
        as_directions([[0, 0, 0]])
    with pytest.raises(InputError, match="NaN"):
        as_directions([[np.nan, 0, 1]])
    with pytest.raises(InputError, match=r"shape \(n, 3\)"):
        as_directions(np.ones((4, 2)))


def test_angle_between_deg():
    np.testing.assert_allclose(angle_between_deg([[1, 0, 0], [0, 1, 0]], [[0, 2, 0], [0, 1, 0]]),
                               [90.0, 0.0], atol=1e-6)


@pytest.mark.parametrize("scale", [1e-20, 3.0, 1e20, 1e37])
def test_coarse_directions_of_a_shape_with_equal_spreads_do_not_depend_on_its_size(scale):
    from vptoolkit.mesh import Mesh

    corner = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])  # two equal spreads
    reference = coarse_directions(Mesh(corner, faces), 16)
    np.testing.assert_allclose(coarse_directions(Mesh(corner * scale, faces), 16), reference,
                               atol=1e-9)
    cube = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
    cube_faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                           [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    np.testing.assert_allclose(coarse_directions(Mesh(cube * scale, cube_faces), 16),
                               coarse_directions(Mesh(cube, cube_faces), 16), atol=1e-9)
