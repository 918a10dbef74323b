"""Depth and silhouette statistics of the views (:mod:`vptoolkit.visibility.features`).

The silhouette is the one OpenCV traces: where ``cv2`` is installed, lengths and
turning histograms are held equal to quoniam's computation on
``cv2.findContours(RETR_LIST, CHAIN_APPROX_NONE)`` for hand-made and random
masks and for rendered sample meshes; without it the hand-made masks still
meet values counted by hand. Depths are held to the camera geometry of a cube,
a square and a sphere worked out by hand, and to a numpy statement of their
definition on random key images; the raster backend to the raycast one; and
drawing the statistics changes no pixel count, whatever the thread count.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.meshes import box_mesh, primitive_mesh
from vptoolkit._numba import threads
from vptoolkit.camera import Camera
from vptoolkit.io import load_mesh
from vptoolkit.mesh import Mesh
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.visibility import (
    RasterScene,
    _frame_features,
    face_id_images,
    iter_view_histograms,
)
from vptoolkit.visibility.features import DEPTH_BINS, THUMBNAIL, TURNING_BINS, ViewFeatures

SQRT2 = np.sqrt(2.0)
DEPTH_LEVELS = 2.0**30  # the keys' quantisation of inverse depth


def _draw(mesh: Mesh, views: Any, resolution: int, backend: str = "raster") -> ViewFeatures:
    settings = MeasureSettings(resolution=resolution, backend=backend)  # type: ignore[arg-type]
    runs = iter_view_histograms(mesh, settings, view_directions=views, features=True)
    return ViewFeatures.concatenate([run.features for run in runs])


def _silhouette(mask: np.ndarray) -> tuple[float, np.ndarray]:
    """Length and turning histogram of a square mask, through the views' own code."""
    features = _frame_features(np.asarray(mask, dtype=np.int64)[None], 1.0, 2.0)
    return features.silhouette_length[0], features.turning_histogram[0]


def _opencv_silhouette(cv2: Any, mask: np.ndarray) -> tuple[float, np.ndarray]:
    """quoniam's statistics (SceneInformationBuilder.cpp) of OpenCV's contours: the
    summed closed arc length, and the oriented angle from ``p[k] - p[k+1]`` to
    ``p[k+1] - p[k+2]`` at every point (0 when equal), in 45-degree bins."""
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    length = sum(cv2.arcLength(contour, True) for contour in contours)
    turning = np.zeros(TURNING_BINS, dtype=np.int64)
    for contour in contours:
        points = contour[:, 0, :].astype(np.int64)
        into = points - np.roll(points, -1, axis=0)
        out = np.roll(into, -1, axis=0)
        cross = into[:, 0] * out[:, 1] - into[:, 1] * out[:, 0]
        angle = np.degrees(np.arctan2(cross, (into * out).sum(axis=1)))  # +180 on reversals
        angle[(into == out).all(axis=1)] = 0.0
        turning += np.bincount(np.rint(angle / 45.0).astype(np.int64) + 4, minlength=TURNING_BINS)
    return length, turning


def _square(side: int, at: tuple[int, int], size: int) -> np.ndarray:
    mask = np.zeros((size, size), dtype=np.uint8)
    mask[at[0]:at[0] + side, at[1]:at[1] + side] = 1
    return mask


def _holed(side: int, hole: int) -> np.ndarray:
    mask = _square(side, (1, 1), side + 2)
    start = 1 + (side - hole) // 2
    mask[start:start + hole, start:start + hole] = 0
    return mask


# mask, length, {turning bin: count}; bin 2 is -90 degrees (a convex corner of an
# outer border, traced counter-clockwise on screen), 4 straight on, 5 and 6 +45
# and +90 (a hole's border turns the other way), 8 a reversal (+180)
HAND_MADE = {
    "square": (_square(6, (2, 1), 10), 4 * 5, {2: 4, 4: 4 * 5 - 4}),
    "square filling the image": (np.ones((6, 6), np.uint8), 4 * 5, {2: 4, 4: 16}),
    "square with a hole": (_holed(7, 3), 4 * 6 + 4 * 2 + 4 * SQRT2, {2: 4, 4: 20 + 4, 5: 8}),
    "square with a one-pixel hole": (_holed(5, 1), 4 * 4 + 4 * SQRT2, {2: 4, 4: 12, 6: 4}),
    "single pixel": (_square(1, (2, 2), 5), 0.0, {4: 1}),
    "two pixels": (_square(1, (1, 1), 4) | _square(1, (1, 2), 4), 2.0, {8: 2}),
    "two blobs": (_square(3, (1, 1), 12) | _square(4, (6, 6), 12), 4 * 2 + 4 * 3,
                  {2: 8, 4: 4 + 8}),
    "nothing": (np.zeros((3, 3), np.uint8), 0.0, {}),
}


@pytest.mark.parametrize("name", list(HAND_MADE))
def test_hand_made_masks_have_the_silhouettes_counted_by_hand(name):
    mask, length, bins = HAND_MADE[name]
    got_length, got_turning = _silhouette(mask)
    expected = np.zeros(TURNING_BINS, dtype=np.int64)
    for b, count in bins.items():
        expected[b] = count
    assert got_length == pytest.approx(length, rel=1e-12, abs=1e-12)
    np.testing.assert_array_equal(got_turning, expected)


def _random_masks() -> list[np.ndarray]:
    """Speckle (thin parts, holes of every shape, pixels touching corner to corner)
    and blobs, some filling the image to its border."""
    from scipy.ndimage import binary_closing

    rng = np.random.default_rng(11)
    masks = []
    for trial in range(300):
        size = int(rng.integers(1, 30))
        mask = rng.random((size, size)) < rng.uniform(0.1, 0.9)
        if trial % 3 == 0 and size > 2:
            mask = binary_closing(mask)
        masks.append(mask.astype(np.uint8))
    return masks


def test_silhouettes_equal_opencv_contours_on_masks():
    require_package("cv2")
    import cv2
    for mask in [case[0] for case in HAND_MADE.values()] + _random_masks():
        length, turning = _opencv_silhouette(cv2, mask)
        got_length, got_turning = _silhouette(mask)
        # OpenCV adds sqrt(2) in float32
        assert got_length == pytest.approx(length, rel=1e-7, abs=1e-7), mask
        np.testing.assert_array_equal(got_turning, turning, err_msg=str(mask))


@pytest.mark.parametrize("name", ["torus.STL", "mug.obj", "table.obj", "bunny.ply"])
def test_silhouettes_of_rendered_meshes_equal_opencv_contours(name):
    require_package("cv2")
    import cv2
    mesh = load_mesh(sample_path(name))
    views = fibonacci_sphere(5)
    for resolution in (97, 160):
        features = _draw(mesh, views, resolution)
        images = face_id_images(mesh, MeasureSettings(resolution=resolution),
                                view_directions=views)
        for view, image in enumerate(images):
            length, turning = _opencv_silhouette(cv2, image >= 0)
            assert features.silhouette_length[view] == pytest.approx(length, rel=1e-7)
            np.testing.assert_array_equal(features.turning_histogram[view], turning)
            assert features.depth_histogram[view].sum() == (image >= 0).sum()


def _cube_frame() -> tuple[float, float]:
    """Half diagonal ``r`` of a unit cube and the camera's distance ``d`` to its centre."""
    r = np.sqrt(3.0) / 2.0
    return r, Camera().distance_factor * 2.0 * r


def test_max_depth_of_a_cube_face_on_and_corner_on():
    r, d = _cube_frame()
    face_on, corner_on = [0, 0, 1], [1, 1, 1]
    features = _draw(box_mesh(), [face_on, corner_on], 384)
    # face-on: the whole front face lies at z = d - 1/2, near = d - r, far = d + r
    flat = (r - 0.5) / (2.0 * r)
    assert features.max_depth[0] == pytest.approx(flat, abs=1e-8)
    assert np.flatnonzero(features.depth_histogram[0]).tolist() == [int(flat * DEPTH_BINS)]
    # corner-on: the nearest corner touches the bounding sphere (depth 0); the three
    # corners with two coordinates against the view lie 1/(2 sqrt 3) behind the
    # centre, at (r + 1/(2 sqrt 3)) / (2 r) = 2/3, sampled within a pixel or two
    assert 2.0 / 3.0 - 0.01 < features.max_depth[1] <= 2.0 / 3.0
    assert features.depth_histogram[1, 0] > 0
    assert features.depth_histogram[1, int(DEPTH_BINS * 2 / 3) + 1:].sum() == 0


def test_a_square_face_on_against_a_sphere():
    square = Mesh(np.array([[-1.0, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]),
                  np.array([[0, 1, 2], [0, 2, 3]]), "square")
    sphere = primitive_mesh("icosphere", {"subdivisions": 4}, "sphere")
    resolution = 256
    flat = _draw(square, [[0, 0, 1]], resolution)
    round_ = _draw(sphere, [[0, 0, 1]], resolution)
    # the square is seen as a square of pixels: one straight border with four corners
    side = int(np.sqrt(flat.depth_histogram[0].sum()))
    assert side**2 == flat.depth_histogram[0].sum()
    assert flat.silhouette_length[0] == 4 * (side - 1)
    assert flat.turning_histogram[0].tolist() == [0, 0, 4, 0, 4 * (side - 1) - 4, 0, 0, 0, 0]
    # ...all of it in the plane of the bounding-box centre, at depth 1/2
    assert flat.max_depth[0] == pytest.approx(0.5, abs=1e-8)
    assert np.flatnonzero(flat.depth_histogram[0]).tolist() == [DEPTH_BINS // 2]
    # the sphere's disc turns by +-45 degrees only, its depths spread from the
    # nearest point (d - rho) to the silhouette circle ((d^2 - rho^2) / d)
    assert round_.turning_histogram[0, [3, 5]].min() > 0
    assert round_.turning_histogram[0].sum() == round_.turning_histogram[0, 3:6].sum()
    rho = np.linalg.norm(sphere.vertices, axis=1).max()
    r = np.linalg.norm(np.ptp(sphere.vertices, axis=0)) / 2.0
    d = Camera().distance_factor * 2.0 * r
    seen = np.flatnonzero(round_.depth_histogram[0])
    assert abs(seen[0] - DEPTH_BINS * (r - rho) / (2 * r)) <= 1
    assert round_.max_depth[0] == pytest.approx((r - rho**2 / d) / (2 * r), abs=0.01)
    assert len(seen) > 20


def _thumbnail_pixels(resolution: int) -> list[range]:
    """Image rows (and columns) that each thumbnail row shows: blocks of
    ``floor(i R / 64) .. floor((i + 1) R / 64) - 1``, or below 64 pixels the pixel
    nearest to the thumbnail pixel's centre."""
    if resolution >= THUMBNAIL:
        edges = np.arange(THUMBNAIL + 1) * resolution // THUMBNAIL
        return [range(edges[i], edges[i + 1]) for i in range(THUMBNAIL)]
    source = ((np.arange(THUMBNAIL) + 0.5) * resolution / THUMBNAIL).astype(np.int64)
    return [range(s, s + 1) for s in source]


@pytest.mark.parametrize("resolution", [1, 5, 40, 64, 100, 130])
def test_depth_statistics_equal_their_definition_on_random_key_images(resolution):
    rng = np.random.default_rng(resolution)
    near, far = 1.3, 2.9
    covered = rng.random((2, resolution, resolution)) < 0.7
    covered[1] = False  # the second view sees nothing
    q = rng.integers(0, int(DEPTH_LEVELS) + 1, covered.shape)
    keys = np.where(covered, (q << 32) | rng.integers(1, 1000, covered.shape), 0)
    features = _frame_features(keys, near, far)

    inverse_far = 1.0 / far
    q_step = (1.0 / near - inverse_far) / DEPTH_LEVELS
    depth = np.clip((1.0 / (q * q_step + inverse_far) - near) * (1.0 / (far - near)), 0.0, 1.0)
    seen = depth[0][covered[0]]
    bins = np.minimum((seen * DEPTH_BINS).astype(np.int64), DEPTH_BINS - 1)
    np.testing.assert_array_equal(features.depth_histogram[0],
                                  np.bincount(bins, minlength=DEPTH_BINS))
    assert features.max_depth[0] == (seen.max() if seen.size else np.nan)
    nearest = np.where(covered[0], depth[0], np.inf)
    pixels = _thumbnail_pixels(resolution)
    blocks = np.array([[nearest[np.ix_(rows, columns)].min() for columns in pixels]
                       for rows in pixels])
    thumbnail = np.where(np.isfinite(blocks), 1 + np.rint(254.0 * (1.0 - blocks)), 0)
    np.testing.assert_array_equal(features.depth_thumbnail[0], thumbnail)
    # a view that sees nothing
    assert np.isnan(features.max_depth[1]) and features.silhouette_length[1] == 0.0
    assert not features.depth_histogram[1].any() and not features.turning_histogram[1].any()
    assert not features.depth_thumbnail[1].any()


@pytest.mark.parametrize("resolution", [40, 256, 300])
def test_thumbnails_are_zero_on_background_and_brightest_nearest(resolution):
    corner_on = [[1.0, 1.0, 1.0]]
    cube = box_mesh()
    thumbnail = _draw(cube, corner_on, resolution).depth_thumbnail[0]
    mask = face_id_images(cube, MeasureSettings(resolution=resolution),
                          view_directions=corner_on)[0] >= 0
    pixels = _thumbnail_pixels(resolution)
    block_seen = [[mask[np.ix_(rows, columns)].any() for columns in pixels] for rows in pixels]
    np.testing.assert_array_equal(thumbnail > 0, block_seen)
    assert thumbnail[0, 0] == 0
    # the corner nearest the camera (depth 0, value 255) is at the image centre
    assert thumbnail.max() >= 250
    centre = {resolution // 2 - 1, resolution // 2}
    assert any(centre & set(pixels[row]) and centre & set(pixels[column])
               for row, column in np.argwhere(thumbnail == thumbnail.max()))


@pytest.mark.parametrize("name", ["bunny.ply", "Duck.glb"])
def test_raster_and_raycast_statistics_agree(name):
    require_package("open3d")
    mesh = load_mesh(sample_path(name))
    views = fibonacci_sphere(6)
    raster, raycast = _draw(mesh, views, 200), _draw(mesh, views, 200, "raycast")
    pixels = raycast.depth_histogram.sum(axis=1)
    l1 = np.abs(raster.depth_histogram - raycast.depth_histogram).sum(axis=1) / pixels
    assert l1.max() < 5e-3, l1
    np.testing.assert_allclose(raster.max_depth, raycast.max_depth, atol=1e-3)
    np.testing.assert_allclose(raster.silhouette_length, raycast.silhouette_length, rtol=0.05)
    turns = raycast.turning_histogram.sum(axis=1)
    turning_l1 = np.abs(raster.turning_histogram - raycast.turning_histogram).sum(axis=1) / turns
    assert turning_l1.max() < 0.08, turning_l1
    levels = np.abs(raster.depth_thumbnail.astype(int) - raycast.depth_thumbnail)
    assert (levels > 2).mean() < 0.01


def test_drawing_the_statistics_leaves_the_pixel_counts_unchanged(bunny):
    views = fibonacci_sphere(10)
    settings = MeasureSettings(resolution=128)
    plain = list(iter_view_histograms(bunny, settings, view_directions=views))
    drawn = list(iter_view_histograms(bunny, settings, view_directions=views, features=True))
    assert all(run.features is None for run in plain)
    assert [run.features.n_views for run in drawn] == [run.n_views for run in drawn]
    for a, b in zip(plain, drawn, strict=True):
        for field in ("offsets", "face_ids", "pixel_counts"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    # a scene drawn with and without them in turn keeps its counts too
    scene = RasterScene(bunny)
    first, with_features, last = (list(scene.histograms(views, 128, features=features))
                                  for features in (False, True, False))
    for a, b, c in zip(first, with_features, last, strict=True):
        np.testing.assert_array_equal(a.pixel_counts, b.pixel_counts)
        np.testing.assert_array_equal(a.pixel_counts, c.pixel_counts)
    assert all(run.features is None for run in last)


def test_statistics_do_not_depend_on_the_thread_count(bunny):
    views = fibonacci_sphere(9)
    results = []
    for n in (1, 2):
        with threads(n):
            results.append(_draw(bunny, views, 200))
    for field in ("depth_histogram", "max_depth", "silhouette_length", "turning_histogram",
                  "depth_thumbnail"):
        np.testing.assert_array_equal(getattr(results[0], field), getattr(results[1], field))


def test_a_view_that_sees_nothing_has_empty_statistics(triangle):
    features = _draw(triangle, [[0, 0, -1], [0, 0, 1]], 64)  # from behind: culled
    assert np.isnan(features.max_depth[0]) and features.silhouette_length[0] == 0.0
    assert not features.depth_histogram[0].any() and not features.turning_histogram[0].any()
    assert not features.depth_thumbnail[0].any()
    assert features.depth_histogram[1].sum() > 0 and features.silhouette_length[1] > 0
