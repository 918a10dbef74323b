"""Known answers of the area (NVT, PA, HM), information (I2, I3) and stability (INS, DVS)
measures."""

import numpy as np
import pytest

from fixtures.meshes import box_mesh, primitive_mesh
from vptoolkit.geometry import face_areas
from vptoolkit.measures.catalog import dvs, ins
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.mesh import Mesh
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.visibility import ViewHistograms, face_pixel_counts, iter_view_histograms
from vptoolkit.visibility.features import DEPTH_BINS, THUMBNAIL, TURNING_BINS, ViewFeatures

PIXEL_MEASURES = "NVT,PA,HM,I2,I3"


def x_log_x(x: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(x > 0, x * np.log2(x), 0.0)


def entropy(p: np.ndarray, axis: int = -1) -> np.ndarray:
    return -x_log_x(p).sum(axis=axis)


def test_pixel_measures_equal_their_formulas_on_a_dense_matrix(bunny):
    views = fibonacci_sphere(40)
    settings = MeasureSettings(resolution=128)
    counts = face_pixel_counts(bunny, settings, view_directions=views).astype(np.float64)
    quality = compute_view_quality(bunny, settings, view_directions=views,
                                   measures=PIXEL_MEASURES)
    nvt, pa, hm, i2, i3 = quality.raw.T
    np.testing.assert_array_equal(nvt, (counts > 0).sum(axis=1))
    np.testing.assert_allclose(pa, counts.sum(axis=1) / 128**2)
    np.testing.assert_allclose(hm, nvt / bunny.n_faces + pa)
    a_t = counts.sum(axis=1)
    p_face = counts.sum(axis=0) / counts.sum()  # p(z)
    p_face_given_view = counts / a_t[:, None]
    np.testing.assert_allclose(i2, entropy(p_face) - entropy(p_face_given_view), rtol=1e-10)
    p_view = a_t / a_t.sum()
    seen = counts.sum(axis=0) > 0
    p_view_given_face = counts[:, seen] / counts[:, seen].sum(axis=0)
    face_i2 = entropy(p_view) - entropy(p_view_given_face, axis=0)  # I2(z; V)
    np.testing.assert_allclose(i3, p_face_given_view[:, seen] @ face_i2, rtol=1e-10)


def test_a_sphere_looks_the_same_from_every_view():
    sphere = primitive_mesh("icosphere", {"subdivisions": 3}, "sphere")
    quality = compute_view_quality(sphere, MeasureSettings(views=200, resolution=128),
                                   measures=PIXEL_MEASURES)
    assert np.isfinite(quality.raw).all()
    spread = np.ptp(quality.raw, axis=0) / np.abs(quality.raw).mean(axis=0)
    assert (spread < 0.05).all(), dict(zip(quality.measures, spread))


def test_a_cube_shows_most_triangles_and_area_from_a_corner(cube):
    corners = np.array([[1, 1, 1], [-1, 1, -1], [1, -1, -1]]) / np.sqrt(3)
    sides = np.array([[0, 0, 1], [1, 0, 0], [0, -1, 0]])
    quality = compute_view_quality(cube, MeasureSettings(resolution=128),
                                   view_directions=np.vstack([corners, sides]),
                                   measures="NVT,PA,HM")
    nvt, pa, hm = quality.raw.T
    np.testing.assert_array_equal(nvt, [6, 6, 6, 2, 2, 2])  # three sides or one, two triangles each
    assert pa[:3].min() > 1.05 * pa[3:].max()
    assert hm[:3].min() > hm[3:].max()
    assert set(quality.best_index) <= {0, 1, 2} and set(quality.worst_index) <= {3, 4, 5}


def test_a_flat_square_seen_edge_on_or_from_behind_sees_nothing():
    square = Mesh(np.array([[-1.0, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]),
                  np.array([[0, 1, 2], [0, 2, 3]]), "square")
    views = [[0, 0, 1], [0.2, 0.1, 1], [1, 0, 0], [0, 1, 0], [0, 0, -1]]
    quality = compute_view_quality(square, MeasureSettings(resolution=96), view_directions=views,
                                   measures="NVT,PA,HM,I2,I3,INS")
    nvt, pa, hm = quality.raw[:, :3].T
    np.testing.assert_array_equal(nvt, [2, 2, 0, 0, 0])
    assert (pa[:2] > 0.1).all() and (pa[2:] == 0).all()
    np.testing.assert_array_equal(hm[2:], 0.0)
    information = quality.raw[:, 3:]
    assert np.isfinite(information[:2]).all() and np.isnan(information[2:]).all()
    np.testing.assert_array_equal(quality.normalized[2:], 0.0)  # nothing seen: worst everywhere


def dense_instability(counts: np.ndarray, neighbours: np.ndarray) -> np.ndarray:
    """Mean Jensen-Shannon divergence with weights a_t / (a_t + a_t'), written out."""
    a_t = counts.sum(axis=1)
    values = np.full(len(counts), np.nan)
    for view, around in enumerate(neighbours):
        divergences = []
        for other in around:
            if a_t[view] == 0 or a_t[other] == 0:
                continue
            weight = a_t[view] / (a_t[view] + a_t[other])
            p, q = counts[view] / a_t[view], counts[other] / a_t[other]
            mixture = weight * p + (1 - weight) * q
            divergences.append(entropy(mixture) - weight * entropy(p) - (1 - weight) * entropy(q))
        if a_t[view] > 0 and divergences:
            values[view] = np.mean(divergences)
    return values


def view_data(mesh: Mesh, views: np.ndarray, settings: MeasureSettings,
              runs: list[ViewHistograms]) -> ViewData:
    return ViewData(mesh, views, settings, face_areas(mesh), runs)


def test_instability_equals_the_jensen_shannon_divergence_written_out(bunny):
    views = fibonacci_sphere(50)
    settings = MeasureSettings(resolution=96)
    counts = face_pixel_counts(bunny, settings, view_directions=views).astype(np.float64)
    data = view_data(bunny, views, settings,
                     list(iter_view_histograms(bunny, settings, view_directions=views)))
    expected = dense_instability(counts, data.neighbours(ins.NEIGHBOURS))
    np.testing.assert_allclose(ins.MEASURE.compute(data), expected, rtol=1e-9, atol=1e-12)


def test_a_sphere_is_more_stable_than_an_elongated_box():
    settings = MeasureSettings(views=200, resolution=256)
    sphere = primitive_mesh("icosphere", {"subdivisions": 3}, "sphere")
    on_sphere = compute_view_quality(sphere, settings, measures="INS").raw[:, 0]
    on_box = compute_view_quality(box_mesh((1.0, 1.0, 4.0)), settings,
                                  measures="INS").raw[:, 0]
    # Every view of the sphere changes alike as the camera moves; views of the box where
    # a side comes into sight change much more than those facing a side.
    assert np.ptp(on_sphere) < 0.5 * on_sphere.mean()
    assert on_sphere.max() < 0.5 * on_box.max()
    assert np.ptp(on_box) > 5 * np.ptp(on_sphere)


def test_instability_is_undefined_where_nothing_or_no_neighbour_is_seen(triangle):
    views = np.array([[0, 0, 1], [0.1, 0, 1], [0, 0, -1], [0.1, 0, -1]], dtype=np.float64)
    views /= np.linalg.norm(views, axis=1, keepdims=True)
    settings = MeasureSettings(resolution=64)
    data = view_data(triangle, views, settings,
                     list(iter_view_histograms(triangle, settings, view_directions=views)))
    values = ins.MEASURE.compute(data)
    np.testing.assert_array_equal(values[:2], 0.0)  # one face: the same distribution
    assert np.isnan(values[2:]).all()  # the back of the triangle: nothing seen


def features_with_thumbnails(thumbnails: np.ndarray) -> ViewFeatures:
    n_views = len(thumbnails)
    return ViewFeatures(
        depth_histogram=np.zeros((n_views, DEPTH_BINS), dtype=np.int64),
        max_depth=np.full(n_views, 0.5),
        silhouette_length=np.zeros(n_views),
        turning_histogram=np.zeros((n_views, TURNING_BINS), dtype=np.int64),
        depth_thumbnail=thumbnails,
    )


def test_depth_stability_counts_neighbours_with_similar_depth_images(triangle):
    """Views above the equator share one smooth depth image, views below have noise.

    A smooth image compresses well with itself (NCD near 0), noise with nothing
    (NCD near 1): DVS counts the upper neighbours of upper views and nothing else.
    """
    views = fibonacci_sphere(40)
    upper = views[:, 2] > 0
    rows, columns = np.mgrid[:THUMBNAIL, :THUMBNAIL]
    disk = np.where((rows - 32) ** 2 + (columns - 32) ** 2 < 400, 60 + rows + columns, 0)
    noise = np.random.default_rng(0).integers(1, 256, size=(40, THUMBNAIL, THUMBNAIL))
    thumbnails = np.where(upper[:, None, None], disk, noise).astype(np.uint8)
    empty = int(np.flatnonzero(upper)[0])  # one upper view sees nothing
    thumbnails[empty] = 0
    seen = np.ones(40, dtype=bool)
    seen[empty] = False
    run = ViewHistograms(offsets=np.concatenate([[0], np.cumsum(seen)]).astype(np.int64),
                         face_ids=np.zeros(int(seen.sum()), dtype=np.int32),
                         pixel_counts=np.full(int(seen.sum()), 100, dtype=np.int32),
                         n_faces=1, features=features_with_thumbnails(thumbnails))
    data = view_data(triangle, views, MeasureSettings(resolution=64), [run])
    values = dvs.MEASURE.compute(data)
    neighbours = data.neighbours(dvs.NEIGHBOURS)
    expected = (upper[neighbours] & seen[neighbours]).sum(axis=1).astype(np.float64)
    expected[~upper] = 0.0
    expected[empty] = np.nan
    np.testing.assert_array_equal(values, expected)
    assert np.nanmax(values) >= dvs.NEIGHBOURS - 2  # a view well inside the upper cap


def test_every_depth_image_of_a_sphere_is_like_its_neighbours():
    sphere = primitive_mesh("icosphere", {"subdivisions": 3}, "sphere")
    quality = compute_view_quality(sphere, MeasureSettings(views=100, resolution=128),
                                   measures="DVS")
    np.testing.assert_array_equal(quality.raw[:, 0], dvs.NEIGHBOURS)


def test_depth_stability_needs_views_drawn_with_depth(cube):
    from vptoolkit.errors import InputError

    settings = MeasureSettings(resolution=32)
    views = fibonacci_sphere(8)
    runs = list(iter_view_histograms(cube, settings, view_directions=views))
    with pytest.raises(InputError, match=r"^box: histograms: drawn without the depth and "
                                         r"silhouette statistics \(needed by DVS\)$"):
        compute_view_quality(cube, settings, view_directions=views, measures="NVT,DVS",
                             histograms=runs)
    pixels_only = compute_view_quality(cube, settings, view_directions=views,
                                       measures="NVT,INS", histograms=runs)
    assert np.isfinite(pixels_only.raw).all()

