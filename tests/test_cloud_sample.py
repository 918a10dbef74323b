"""The stored sample of a point cloud: its own points thinned or repeated, normals kept or fit."""

from __future__ import annotations

import numpy as np
import pytest

from vptoolkit.cloud_sample import estimate_normals, sample_cloud
from vptoolkit.errors import InputError
from vptoolkit.point_cloud import PointCloud
from vptoolkit.sphere import fibonacci_sphere


def sphere(n: int, *, normals: bool) -> PointCloud:
    """``n`` points on the sphere of radius 2 about (1, 1, 1); outward normals if asked."""
    directions = fibonacci_sphere(n)
    return PointCloud(1.0 + 2.0 * directions, directions if normals else None, name="sphere")


def test_thinning_keeps_distinct_points_in_cloud_order_with_their_normals():
    cloud = sphere(1000, normals=True)
    sample = sample_cloud(cloud, 300, seed=4)
    rows = np.flatnonzero((cloud.points[:, None] == sample.points[None]).all(axis=2).any(axis=1))
    assert len(rows) == 300
    assert np.array_equal(sample.points, cloud.points[rows])  # sorted rows: the cloud's order
    assert np.array_equal(sample.normals, cloud.normals[rows])
    again = sample_cloud(cloud, 300, seed=4)
    assert np.array_equal(again.points, sample.points)
    assert not np.array_equal(sample_cloud(cloud, 300, seed=5).points, sample.points)


def test_a_small_cloud_is_every_point_then_repeats():
    cloud = sphere(100, normals=True)
    sample = sample_cloud(cloud, 250, seed=0)
    assert sample.points.shape == (250, 3)
    assert len(np.unique(sample.points, axis=0)) == 100
    assert np.array_equal(sample_cloud(cloud, 100).points, cloud.points)


def test_estimated_normals_of_a_sphere_point_outward():
    cloud = sphere(4000, normals=False)
    sample = sample_cloud(cloud, 500, seed=1)
    radial = (sample.points - 1.0) / 2.0
    assert np.allclose(np.linalg.norm(sample.normals, axis=1), 1.0)
    assert np.einsum("ni,ni->n", sample.normals, radial).min() > 0.99
    assert np.allclose(estimate_normals(cloud.points)[:3], fibonacci_sphere(4000)[:3], atol=0.02)


def test_bad_arguments_are_one_line():
    with pytest.raises(InputError, match="cloud: expected a PointCloud"):
        sample_cloud(np.zeros((10, 3)), 5)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="n:"):
        sample_cloud(sphere(10, normals=True), 0)
    with pytest.raises(InputError, match="need more than k = 8"):
        estimate_normals(np.eye(3))
