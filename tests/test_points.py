"""Tests of vptoolkit.points: area-uniform surface sampling and the network input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.spatial import cKDTree

from fixtures.environment import require_package
from vptoolkit.errors import InputError
from vptoolkit.mesh import Mesh
from vptoolkit.points import (
    SurfaceSample,
    farthest_point_sampling,
    network_input,
    network_input_indices,
    sample_surface,
)


@pytest.fixture(scope="module")
def two_triangles() -> Mesh:
    """Two right triangles in the z = 0 plane with areas 0.5 and 50 (ratio 1:100)."""
    vertices = np.array(
        [[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [12, 0, 0], [2, 10, 0]], dtype=np.float64
    )
    faces = np.array([[0, 1, 2], [3, 4, 5]], dtype=np.int64)
    return Mesh(vertices, faces, name="two_triangles")


@pytest.fixture(scope="module")
def uneven_box() -> Mesh:
    """A closed unit box whose +x side is split into 32 slivers and one big triangle."""
    # Bottom z=0, top z=1, sides; the +x side (x=1) is a fan of many faces.
    corners = np.array(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
        dtype=np.float64,
    )
    faces = [
        [0, 2, 1], [0, 3, 2],  # bottom, normal -z
        [4, 5, 6], [4, 6, 7],  # top, normal +z
        [0, 1, 5], [0, 5, 4],  # front y=0, normal -y
        [3, 7, 6], [3, 6, 2],  # back y=1, normal +y
        [0, 4, 7], [0, 7, 3],  # left x=0, normal -x
    ]
    # Right side x=1 as a fan around (1, 1, 1): many slivers along the edge z=0.
    n_split = 32
    ys = np.linspace(0.0, 1.0, n_split + 1)
    extra = np.column_stack([np.ones(n_split + 1), ys, np.zeros(n_split + 1)])
    base = len(corners)
    vertices = np.vstack([corners, extra])
    for i in range(n_split):
        faces.append([base + i, base + i + 1, 6])
    faces.append([1, 6, 5])
    return Mesh(vertices, np.array(faces), name="uneven_box")


@pytest.fixture(scope="module")
def sphere_points() -> np.ndarray:
    """20k points uniformly on the unit sphere."""
    rng = np.random.default_rng(7)
    points = rng.normal(size=(20_000, 3))
    return points / np.linalg.norm(points, axis=1, keepdims=True)


def _face_areas(mesh: Mesh) -> np.ndarray:
    corners = mesh.vertices[mesh.faces]
    return 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )


def test_sample_surface_shapes_and_types(uneven_box: Mesh) -> None:
    sample = sample_surface(uneven_box, 500, seed=3)
    assert isinstance(sample, SurfaceSample)
    points, normals, face_index = sample
    assert points.shape == (500, 3) and points.dtype == np.float64
    assert normals.shape == (500, 3) and normals.dtype == np.float64
    assert face_index.shape == (500,) and face_index.dtype == np.int64
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert face_index.min() >= 0 and face_index.max() < uneven_box.n_faces


def test_sample_surface_points_lie_on_their_faces(uneven_box: Mesh) -> None:
    points, normals, face_index = sample_surface(uneven_box, 2000, seed=0)
    corners = uneven_box.vertices[uneven_box.faces[face_index]]
    # Distance to the face plane is zero, and the point is inside the triangle.
    heights = np.einsum("ij,ij->i", points - corners[:, 0], normals)
    np.testing.assert_allclose(heights, 0.0, atol=1e-12)
    for k in range(3):
        edge = corners[:, (k + 1) % 3] - corners[:, k]
        side = np.einsum("ij,ij->i", np.cross(edge, points - corners[:, k]), normals)
        assert (side >= -1e-12).all()
    # Normals point out of the box: from the box centre to the point.
    assert (np.einsum("ij,ij->i", points - 0.5, normals) > 0).all()


def test_sample_surface_is_uniform_by_area_chi_square(two_triangles: Mesh) -> None:
    n = 20_000
    _, _, face_index = sample_surface(two_triangles, n, seed=11)
    areas = _face_areas(two_triangles)
    expected = n * areas / areas.sum()
    observed = np.bincount(face_index, minlength=2)
    assert observed[0] > 0  # the small face is still sampled
    assert stats.chisquare(observed, expected).pvalue > 1e-3


def test_sample_surface_is_uniform_by_area_on_many_faces(uneven_box: Mesh) -> None:
    n = 60_000
    _, _, face_index = sample_surface(uneven_box, n, seed=5)
    areas = _face_areas(uneven_box)
    expected = n * areas / areas.sum()
    observed = np.bincount(face_index, minlength=uneven_box.n_faces)
    assert stats.chisquare(observed, expected).pvalue > 1e-3


def test_sample_surface_is_uniform_inside_a_triangle(two_triangles: Mesh) -> None:
    points, _, face_index = sample_surface(two_triangles, 20_000, seed=2)
    big = points[face_index == 1]
    # Mean of a uniform distribution on a triangle is its centroid (2+12+2)/3, 10/3.
    np.testing.assert_allclose(big[:, :2].mean(axis=0), [16 / 3, 10 / 3], atol=0.1)
    # Fraction below half height is 1 - (1/2)^2 = 3/4 for a uniform density.
    assert abs((big[:, 1] < 5.0).mean() - 0.75) < 0.015


def test_sample_surface_skips_zero_area_faces() -> None:
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], dtype=np.float64)
    faces = np.array([[0, 1, 3], [0, 1, 2], [1, 3, 0]])  # faces 0 and 2 are collinear
    mesh = Mesh(vertices, faces, name="slivers")
    _, normals, face_index = sample_surface(mesh, 1000, seed=0)
    assert set(face_index.tolist()) == {1}
    assert np.isfinite(normals).all()


def test_sample_surface_is_deterministic_per_seed(uneven_box: Mesh) -> None:
    first = sample_surface(uneven_box, 1000, seed=42)
    second = sample_surface(uneven_box, 1000, seed=42)
    other = sample_surface(uneven_box, 1000, seed=43)
    for a, b in zip(first, second):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(first.points, other.points)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n": 0}, "n: must be at least 1"),
        ({"n": 2.5}, "n: expected an integer"),
        ({"seed": 1.5}, "seed: expected an integer"),
    ],
    ids=["zero-points", "float-points", "float-seed"],
)
def test_sample_surface_rejects_bad_options(uneven_box: Mesh, kwargs: dict, message: str) -> None:
    with pytest.raises(InputError, match=message):
        sample_surface(uneven_box, **kwargs)


def test_sample_surface_rejects_zero_area_mesh() -> None:
    collinear = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], dtype=np.float64)
    flat = Mesh(collinear, np.array([[0, 1, 2]]), name="flat")
    with pytest.raises(InputError, match="^flat: mesh has zero surface area"):
        sample_surface(flat, 10)


def test_sample_surface_rejects_non_mesh() -> None:
    with pytest.raises(InputError, match="mesh: expected a vptoolkit Mesh"):
        sample_surface(np.zeros((3, 3)), 10)  # type: ignore[arg-type]


def test_fps_spreads_points_far_more_than_random(sphere_points: np.ndarray) -> None:
    rng = np.random.default_rng(0)
    fps = farthest_point_sampling(sphere_points, 1024, rng=rng)
    random = rng.choice(len(sphere_points), 1024, replace=False)

    def min_pairwise(idx: np.ndarray) -> float:
        distances, _ = cKDTree(sphere_points[idx]).query(sphere_points[idx], k=2)
        return float(distances[:, 1].min())

    # 1024 well spread points on the unit sphere are about 0.11 apart; random
    # points come much closer to each other.
    assert min_pairwise(fps) > 0.05
    assert min_pairwise(fps) > 5 * min_pairwise(random)


def test_fps_covers_the_cloud(sphere_points: np.ndarray) -> None:
    idx = farthest_point_sampling(sphere_points, 256, start_index=0)
    distances, _ = cKDTree(sphere_points[idx]).query(sphere_points)
    # Covering radius of 256 caps on the unit sphere is about 0.14.
    assert distances.max() < 0.25


def test_fps_indices_are_distinct_and_start_where_asked(sphere_points: np.ndarray) -> None:
    idx = farthest_point_sampling(sphere_points, 100, start_index=17)
    assert idx.dtype == np.int64 and idx.shape == (100,)
    assert idx[0] == 17
    assert len(np.unique(idx)) == 100
    # Second pick is the point farthest from the start.
    expected = np.argmax(np.linalg.norm(sphere_points - sphere_points[17], axis=1))
    assert idx[1] == expected


def test_fps_is_exact_on_a_line() -> None:
    line = np.column_stack([np.arange(11.0), np.zeros(11), np.zeros(11)]) + 1000.0
    idx = farthest_point_sampling(line, 3, start_index=0)
    np.testing.assert_array_equal(idx, [0, 10, 5])


def test_fps_with_duplicate_points_never_repeats() -> None:
    points = np.zeros((10, 3))
    idx = farthest_point_sampling(points, 10, start_index=3)
    assert sorted(idx.tolist()) == list(range(10))


def test_fps_is_deterministic_per_rng(sphere_points: np.ndarray) -> None:
    a = farthest_point_sampling(sphere_points, 64, rng=np.random.default_rng(5))
    b = farthest_point_sampling(sphere_points, 64, rng=np.random.default_rng(5))
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    ("n_samples", "kwargs", "message"),
    [
        (0, {}, "n_samples: must be at least 1"),
        (20_001, {}, "n_samples: cannot pick 20001 distinct points from 20000"),
        (5, {"start_index": 20_000}, r"start_index: expected an integer in \[0, 20000\)"),
        (5, {"rng": 3}, "rng: expected a numpy.random.Generator"),
    ],
    ids=["zero", "too-many", "start-out-of-range", "int-rng"],
)
def test_fps_rejects_bad_arguments(
    sphere_points: np.ndarray, n_samples: int, kwargs: dict, message: str
) -> None:
    with pytest.raises(InputError, match=message):
        farthest_point_sampling(sphere_points, n_samples, **kwargs)


def test_network_input_shapes_and_composition(sphere_points: np.ndarray) -> None:
    idx = network_input_indices(sphere_points, rng=np.random.default_rng(1))
    assert idx.shape == (4096,) and idx.dtype == np.int64
    assert len(np.unique(idx)) == 4096  # 20k points are enough: no repeats
    fps = farthest_point_sampling(sphere_points, 1024, rng=np.random.default_rng(1))
    np.testing.assert_array_equal(idx[:1024], fps)
    points = network_input(sphere_points, rng=np.random.default_rng(1))
    assert points.shape == (4096, 3) and points.dtype == np.float64
    np.testing.assert_array_equal(points, sphere_points[idx])


def test_network_input_indices_gather_normals(uneven_box: Mesh) -> None:
    sample = sample_surface(uneven_box, 5000, seed=0)
    idx = network_input_indices(sample.points, 512, 128, rng=np.random.default_rng(0))
    normals = sample.normals[idx]
    assert normals.shape == (512, 3)


def test_network_input_is_deterministic_per_rng(sphere_points: np.ndarray) -> None:
    a = network_input(sphere_points, rng=np.random.default_rng(9))
    b = network_input(sphere_points, rng=np.random.default_rng(9))
    c = network_input(sphere_points, rng=np.random.default_rng(10))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_network_input_with_more_slots_than_points(sphere_points: np.ndarray) -> None:
    few = sphere_points[:2000]
    idx = network_input_indices(few, 4096, 1024, rng=np.random.default_rng(0))
    assert idx.shape == (4096,)
    assert len(np.unique(idx[:1024])) == 1024
    # The random part repeats points but never a farthest-point pick.
    assert not np.isin(idx[1024:], idx[:1024]).any()
    assert len(np.unique(idx)) == 2000


def test_network_input_when_fps_takes_every_point(sphere_points: np.ndarray) -> None:
    idx = network_input_indices(sphere_points[:100], 150, 100, rng=np.random.default_rng(0))
    assert sorted(idx[:100].tolist()) == list(range(100))
    assert idx.shape == (150,) and idx.max() < 100


def test_network_input_without_fps(sphere_points: np.ndarray) -> None:
    idx = network_input_indices(sphere_points, 300, 0, rng=np.random.default_rng(0))
    assert idx.shape == (300,) and len(np.unique(idx)) == 300


@pytest.mark.parametrize(
    ("points", "kwargs", "message"),
    [
        (np.zeros((500, 3)), {}, "points: 500 points, fewer than the n_fps=1024"),
        (np.zeros((5000, 2)), {}, r"points: expected shape \(n, 3\)"),
        (np.full((5000, 3), np.nan), {}, "points: contains NaN"),
        (np.zeros((5000, 3)), {"n": 100, "n_fps": 200}, "n_fps: 200 farthest points exceed"),
        (np.zeros((5000, 3)), {"n_fps": -1}, "n_fps: expected a non-negative integer"),
    ],
    ids=["too-few-points", "wrong-shape", "nan", "fps-above-n", "negative-fps"],
)
def test_network_input_rejects_bad_arguments(
    points: np.ndarray, kwargs: dict, message: str
) -> None:
    with pytest.raises(InputError, match=message):
        network_input(points, rng=np.random.default_rng(0), **kwargs)


def test_network_input_requires_a_generator(sphere_points: np.ndarray) -> None:
    with pytest.raises(InputError, match="rng: expected a numpy.random.Generator"):
        network_input(sphere_points, rng=0)  # type: ignore[arg-type]


def test_poisson_disk_points_are_on_the_surface_and_evenly_spaced() -> None:
    require_package("open3d")
    from vptoolkit.io import load_mesh
    from vptoolkit.points import poisson_disk_points
    from vptoolkit.samples import sample_path

    mesh = load_mesh(sample_path("bunny.ply"))
    points = poisson_disk_points(mesh, 2000, seed=3)
    assert points.shape == (2000, 3)
    np.testing.assert_array_equal(points, poisson_disk_points(mesh, 2000, seed=3))
    # On the surface: every point is near a dense uniform sample of it.
    dense = sample_surface(mesh, 200_000, seed=0).points
    diagonal = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    assert cKDTree(dense).query(points)[0].max() < 0.01 * diagonal
    # Blue noise: the closest pair is much farther apart than in a uniform sample of the same size.
    uniform = sample_surface(mesh, 2000, seed=3).points
    nearest_poisson = cKDTree(points).query(points, k=2)[0][:, 1]
    nearest_uniform = cKDTree(uniform).query(uniform, k=2)[0][:, 1]
    assert nearest_poisson.min() > 3 * nearest_uniform.min()
    spread = nearest_poisson.std() / nearest_poisson.mean()
    assert spread < nearest_uniform.std() / nearest_uniform.mean()


def test_poisson_disk_points_rejects_bad_counts(two_triangles: Mesh) -> None:
    from vptoolkit.points import poisson_disk_points

    with pytest.raises(InputError, match="n"):
        poisson_disk_points(two_triangles, 0)
