"""The compiled sums of the measures and the shared quantities of ViewData against numpy.

Each kernel of :mod:`vptoolkit.measures._kernels` is checked against the
numpy statement of its sum on small cases: the drawn views of an icosphere
and hand-made counts (with a short table of ``x log2 x``, so that both of
its branches run). The partial sort of ``ViewData.neighbours``, the thread
pool of DVS's compressed sizes and the per-view sums must give exactly what
the full sort, one thread and ``np.bincount`` give.
"""

from __future__ import annotations

import itertools
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from fixtures.meshes import primitive_mesh
from vptoolkit.geometry import face_areas
from vptoolkit.measures._kernels import (
    gaussian_sums,
    pair_divergence_sums,
    segment_sums,
    view_pair_sums,
)
from vptoolkit.measures.catalog.dvs import CHUNK, compressed_size, compressed_sizes
from vptoolkit.measures.data import XLOGX_TABLE_SIZE, ViewData
from vptoolkit.measures.saliency import _gaussian_means, face_neighbours
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.visibility import ViewHistograms, iter_view_histograms


def xlogx(values: np.ndarray) -> np.ndarray:
    return values * np.log2(values)


@pytest.fixture(scope="module")
def sphere_views() -> ViewData:
    mesh = primitive_mesh("icosphere", {"subdivisions": 2}, "sphere")
    settings = MeasureSettings(views=60, resolution=48)
    runs = list(iter_view_histograms(mesh, settings))
    return ViewData(mesh, settings.directions(), settings, face_areas(mesh), runs)


@pytest.fixture(scope="module")
def hand_made() -> ViewData:
    """Four views of eight faces of an icosphere, counts from 1 to 40, one view empty."""
    mesh = primitive_mesh("icosphere", {"subdivisions": 0}, "ico")
    dense = np.zeros((4, mesh.n_faces), dtype=np.int64)
    dense[0, :8] = [1, 2, 3, 40, 5, 6, 7, 8]
    dense[1, :8] = [3, 0, 9, 1, 17, 0, 2, 30]
    dense[3, 2:10] = [4, 4, 11, 1, 1, 25, 6, 2]
    rows, faces = np.nonzero(dense)
    offsets = np.concatenate([[0], np.cumsum(np.count_nonzero(dense, axis=1))])
    run = ViewHistograms(offsets.astype(np.int64), faces.astype(np.int32),
                         dense[rows, faces].astype(np.int32), mesh.n_faces)
    settings = MeasureSettings(views=4, resolution=64)
    return ViewData(mesh, fibonacci_sphere(4), settings, face_areas(mesh), [run])


def dense_counts(data: ViewData) -> np.ndarray:
    views, faces, counts = data.entries
    dense = np.zeros((data.n_views, data.n_faces))
    dense[views, faces] = counts
    return dense


def tables(data: ViewData) -> list[np.ndarray]:
    """The data's table of ``x log2 x`` and a short one that leaves most sums to the log."""
    return [data.xlogx_table, data.xlogx_table[:5]]


@pytest.mark.parametrize("case", ["sphere_views", "hand_made"])
def test_pair_divergence_sums_are_the_sums_over_the_views_that_see_both_faces(case, request):
    data = request.getfixturevalue(case)
    dense = dense_counts(data)
    pairs = face_neighbours(data.mesh)
    _, faces, counts = data.entries
    pair_starts = np.searchsorted(pairs[:, 0], np.arange(data.n_faces + 1))
    expected = np.zeros(len(pairs))
    for row, (face, other) in enumerate(pairs):
        a, b = dense[:, face], dense[:, other]
        both = (a > 0) & (b > 0)
        expected[row] = np.sum(xlogx(a[both]) + xlogx(b[both]) - xlogx(a[both] + b[both]))
    assert np.count_nonzero(expected) >= 10
    for table in tables(data):
        shared = pair_divergence_sums(data.view_starts, faces, counts, data.entry_xlogx, table,
                                      pair_starts, np.ascontiguousarray(pairs[:, 1]),
                                      data.n_faces)
        np.testing.assert_allclose(shared, expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("case", ["sphere_views", "hand_made"])
def test_view_pair_sums_are_the_sums_over_the_faces_both_views_see(case, request):
    data = request.getfixturevalue(case)
    dense = dense_counts(data)
    pairs = np.array(list(itertools.combinations(range(data.n_views), 2)), dtype=np.int64)
    walk, other = pairs[:, 0], pairs[:, 1]
    order = np.argsort(other, kind="stable").astype(np.int64)
    _, faces, counts = data.entries
    expected = np.zeros(len(pairs))
    for row, (first, second) in enumerate(pairs):
        a, b = dense[first], dense[second]
        both = (a > 0) & (b > 0)
        expected[row] = np.sum(xlogx(a[both] + b[both]) - xlogx(a[both]) - xlogx(b[both]))
    assert np.count_nonzero(expected) > 0
    for table in tables(data):
        shared = view_pair_sums(data.view_starts, faces, counts, data.entry_xlogx, table,
                                walk, other, order, data.n_faces)
        np.testing.assert_allclose(shared, expected, rtol=1e-12, atol=1e-12)


def test_the_table_holds_x_log_x_of_the_sums_of_two_counts(hand_made):
    table = hand_made.xlogx_table
    assert len(table) == 2 * 40 + 1 <= XLOGX_TABLE_SIZE
    assert table[0] == 0.0 and table[1] == 0.0 and table[2] == 2.0
    np.testing.assert_allclose(table[1:], xlogx(np.arange(1.0, 81.0)), rtol=1e-15)


def test_gaussian_sums_are_the_sums_over_all_points_within_two_sigma():
    rng = np.random.default_rng(7)
    points = rng.uniform(-1.0, 1.0, size=(300, 3)) * [1.0, 0.5, 0.2]
    values = rng.normal(size=300)
    sigmas = np.array([0.05, 0.1, 0.2])
    squared = ((points[:, None, :] - points[None, :, :]) ** 2).sum(axis=2)
    expected = np.empty((300, 3))
    for column, sigma in enumerate(sigmas):
        weights = np.where(squared < (2 * sigma) ** 2, np.exp(-squared / (2 * sigma**2)), 0.0)
        expected[:, column] = weights @ values / weights.sum(axis=1)
    np.testing.assert_allclose(_gaussian_means(points, values, sigmas), expected,
                               rtol=1e-12, atol=1e-14)


def test_gaussian_sums_search_only_the_cells_given():
    points = np.array([[0.0, 0, 0], [0.1, 0, 0], [0.3, 0, 0]])
    keys = np.array([0, 0, 1], dtype=np.int64)
    order = np.arange(3, dtype=np.int64)
    limits, divisors = np.array([1.0]), np.array([-2.0])
    weights, weighted = gaussian_sums(points, np.array([1.0, 2.0, 4.0]), limits, divisors,
                                      keys, keys, order, np.array([0], dtype=np.int64))
    near = np.exp(0.01 / -2.0)
    np.testing.assert_allclose(weights[:, 0], [1 + near, near + 1, 1.0], rtol=1e-15)
    np.testing.assert_allclose(weighted[:, 0], [1 + 2 * near, near + 2, 4.0], rtol=1e-15)


def test_segment_sums_are_bincount_to_the_bit():
    rng = np.random.default_rng(3)
    sizes = rng.integers(0, 5, size=40)
    sizes[[0, 7, 39]] = 0
    weights = rng.normal(size=int(sizes.sum()))
    starts = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    expected = np.bincount(np.repeat(np.arange(40), sizes), weights=weights, minlength=40)
    assert segment_sums(starts, weights).tobytes() == expected.tobytes()


def test_per_view_sums_are_bincount_to_the_bit(sphere_views):
    views, _, counts = sphere_views.entries
    weights = np.sqrt(counts)
    expected = np.bincount(views, weights=weights, minlength=sphere_views.n_views)
    assert sphere_views.per_view(weights).tobytes() == expected.tobytes()
    with pytest.raises(ValueError, match="weights of shape"):
        sphere_views.per_view(weights[:-1])


def _unit(rows: np.ndarray) -> np.ndarray:
    return rows / np.linalg.norm(rows, axis=1, keepdims=True)


@pytest.mark.parametrize("views", [
    fibonacci_sphere(200),
    fibonacci_sphere(1000),
    np.repeat(fibonacci_sphere(12), 3, axis=0),  # ties: equal views
    np.array([[0.0, 0, 1]] * 4 + [[0, 1, 0]] * 3),
    np.vstack([np.eye(3), -np.eye(3)]),  # every other view but the opposite one ties
    _unit(np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)),
    _unit(np.random.default_rng(4).normal(size=(2000, 3))),
    fibonacci_sphere(2),
    fibonacci_sphere(1),
])
def test_neighbours_are_the_start_of_the_stable_full_sort(views, sphere_views):
    data = ViewData(sphere_views.mesh, views, sphere_views.settings, sphere_views.areas, [])
    # Each dot product summed in axis order, so copies of one view tie exactly; a BLAS
    # product (views @ views.T) can round them apart by where they sit in its blocks.
    cosines = (views[:, None, :] * views[None, :, :]).sum(axis=-1)
    np.fill_diagonal(cosines, -np.inf)
    full = np.argsort(-cosines, axis=1, kind="stable")
    for count in (1, 4, 6, 12, 40, 400):
        expected = full[:, :min(count, len(views) - 1)]
        assert np.array_equal(data.neighbours(count), expected), count


def test_compressed_sizes_on_threads_are_those_of_one_image_at_a_time():
    rng = np.random.default_rng(5)
    thumbnails = rng.integers(0, 4, size=(30, 16, 16), dtype=np.uint8) * 60
    thumbnails[:, :8] = 0  # some runs for deflate to find
    pairs = rng.integers(0, 30, size=(CHUNK + 40, 2)).astype(np.int64)
    expected = [compressed_size(np.hstack([thumbnails[a], thumbnails[b]])) for a, b in pairs]
    with ThreadPoolExecutor(2) as pool:
        assert compressed_sizes(thumbnails, pairs, pool).tolist() == expected
    assert compressed_sizes(thumbnails, pairs, None).tolist() == expected
    singles = np.arange(30, dtype=np.int64)[:, None]
    assert compressed_sizes(thumbnails, singles, None).tolist() == [
        compressed_size(image) for image in thumbnails]
