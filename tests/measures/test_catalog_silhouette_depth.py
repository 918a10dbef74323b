"""The silhouette, depth and curvature-entropy measures and the per-face mean curvature.

The measures run on a ViewData built from hand-made pixel counts and image
statistics, where each value is known by hand; the curvature on meshes whose
curvature is known in closed form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fixtures.meshes import box_mesh, primitive_mesh
from vptoolkit.geometry import face_areas
from vptoolkit.measures.catalog.ce import curvature_bins
from vptoolkit.measures.curvature import CACHE_KEY, face_mean_curvature, mesh_curvature
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.registry import get_measure, resolve_measures
from vptoolkit.mesh import Mesh
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.visibility import ViewHistograms, iter_view_histograms
from vptoolkit.visibility.features import DEPTH_BINS, THUMBNAIL, TURNING_BINS, ViewFeatures

NEW_MEASURES = ("SL", "SE", "SC", "SCE", "MD", "DD", "SS", "CE")


def turning(**angles: int) -> np.ndarray:
    """A turning-angle histogram row from counts per angle, ``turning(a0=4, a90=4)``;
    ``am45`` for -45 degrees."""
    row = np.zeros(TURNING_BINS, dtype=np.int64)
    for key, count in angles.items():
        degrees = -int(key[2:]) if key.startswith("am") else int(key[1:])
        row[(degrees + 180) // 45] = count
    return row


def depth_row(**bins: int) -> np.ndarray:
    """A depth histogram row from counts per bin, ``depth_row(b0=3, b255=1)``."""
    row = np.zeros(DEPTH_BINS, dtype=np.int64)
    for key, count in bins.items():
        row[int(key[1:])] = count
    return row


def view_data(mesh: Mesh, counts: np.ndarray, *, max_depth=None, silhouette_length=None,
              turning_histogram=None, depth_histogram=None) -> ViewData:
    """A ViewData of hand-made dense pixel counts ``(n_views, n_faces)``, split into two runs,
    with the image statistics given (zeros where not given)."""
    counts = np.asarray(counts, dtype=np.int64)
    n_views = len(counts)

    def column(values, shape, dtype):
        return np.zeros(shape, dtype) if values is None else np.asarray(values, dtype=dtype)

    features = ViewFeatures(
        depth_histogram=column(depth_histogram, (n_views, DEPTH_BINS), np.int64),
        max_depth=column(max_depth, (n_views,), np.float64),
        silhouette_length=column(silhouette_length, (n_views,), np.float64),
        turning_histogram=column(turning_histogram, (n_views, TURNING_BINS), np.int64),
        depth_thumbnail=np.zeros((n_views, THUMBNAIL, THUMBNAIL), dtype=np.uint8),
    )
    runs = []
    for start, stop in ((0, n_views // 2), (n_views // 2, n_views)):
        block = counts[start:stop]
        rows, faces = np.nonzero(block)
        offsets = np.concatenate([[0], np.cumsum(np.count_nonzero(block, axis=1))])
        part = ViewFeatures(*(getattr(features, name)[start:stop] for name in (
            "depth_histogram", "max_depth", "silhouette_length", "turning_histogram",
            "depth_thumbnail")))
        runs.append(ViewHistograms(offsets.astype(np.int64), faces.astype(np.int32),
                                   block[rows, faces].astype(np.int32), mesh.n_faces,
                                   first_view=start, features=part))
    settings = MeasureSettings(views=n_views, resolution=64)
    return ViewData(mesh, fibonacci_sphere(n_views), settings, face_areas(mesh), runs)


def compute(name: str, data: ViewData) -> np.ndarray:
    values = get_measure(name).compute(data)
    assert values.shape == (data.n_views,) and values.dtype == np.float64
    return values


@pytest.fixture(scope="module")
def square() -> Mesh:
    """Two triangles making the unit square in z = 0."""
    return Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]),
                np.array([[0, 1, 2], [0, 2, 3]]), "square")


def grid_mesh(n: int, size: float = 1.0) -> Mesh:
    """A flat ``n`` x ``n`` grid of squares in z = 0, each cut into two triangles."""
    ticks = np.linspace(0.0, size, n + 1)
    x, y = np.meshgrid(ticks, ticks, indexing="ij")
    vertices = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    index = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b = index[:-1, :-1].ravel(), index[1:, :-1].ravel()
    c, d = index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return Mesh(vertices, faces, "grid")


# --- registry ------------------------------------------------------------------------------


def test_the_new_measures_are_registered_by_family_in_order():
    expected = {
        "SL": ("silhouette", 0, {"silhouette"}), "SE": ("silhouette", 1, {"silhouette"}),
        "SC": ("silhouette", 2, {"silhouette"}), "SCE": ("silhouette", 3, {"silhouette"}),
        "MD": ("depth", 0, {"depth"}), "DD": ("depth", 1, {"depth"}),
        "SS": ("depth", 2, {"depth", "pixels"}), "CE": ("surface", 0, {"pixels", "curvature"}),
    }
    listed = resolve_measures("all")
    for name, (family, place, needs) in expected.items():
        measure = get_measure(name)
        same_family = [other for other in listed if get_measure(other).family == family]
        assert (measure.family, same_family.index(name), set(measure.needs)) == (
            family, place, needs)
        assert measure.higher_is_better
    listed = resolve_measures("all")
    silhouette = [name for name in listed if get_measure(name).family == "silhouette"]
    assert silhouette[:4] == ["SL", "SE", "SC", "SCE"]
    assert [name for name in listed if name in ("MD", "DD", "SS")] == ["MD", "DD", "SS"]
    assert resolve_measures("SL,CE") == ("SL", "CE")


# --- silhouette ---------------------------------------------------------------------------


def test_silhouette_length_is_the_chain_length_and_nan_without_silhouette(square):
    # A 3 x 3 pixel block: 8 axis steps. A diamond of four diagonal steps: 4 sqrt 2.
    data = view_data(square, [[9, 0], [3, 2], [0, 0], [1, 0]],
                     silhouette_length=[8.0, 4 * math.sqrt(2), 0.0, 0.0],
                     turning_histogram=[turning(a0=4, a90=4), turning(a0=0, a90=4),
                                        turning(), turning(a0=1)])
    np.testing.assert_allclose(compute("SL", data), [8.0, 4 * math.sqrt(2), np.nan, 0.0])


def test_silhouette_entropy_is_zero_for_one_angle_and_log2_k_for_k_equal_bins(square):
    rows = [turning(a0=12), turning(a90=4), turning(a0=4, a90=4),
            turning(am90=5, a0=5, a90=5), turning(am135=2, am90=2, am45=2, a0=2, a45=2, a90=2,
                                                  a135=2, a180=2), turning()]
    data = view_data(square, [[1, 1]] * 5 + [[0, 0]], turning_histogram=rows)
    np.testing.assert_allclose(compute("SE", data), [0.0, 0.0, 1.0, math.log2(3), 3.0, np.nan],
                               atol=1e-12)


def test_silhouette_curvature_and_extrema_from_a_hand_histogram(square):
    # 3 x 3 block: four straight pixels and four right-angle corners.
    # Mixed: one -135, two 0, one 180: SC = (1.5 + 0 + 0 + 2) / 4, SCE = (2.25 + 4) / 4.
    rows = [turning(a0=4, a90=4), turning(am135=1, a0=2, a180=1), turning(a0=7), turning()]
    data = view_data(square, [[1, 0], [0, 1], [1, 1], [0, 0]], turning_histogram=rows)
    np.testing.assert_allclose(compute("SC", data), [0.5, 0.875, 0.0, np.nan])
    np.testing.assert_allclose(compute("SCE", data), [0.5, 1.5625, 0.0, np.nan])


# --- depth --------------------------------------------------------------------------------


def test_maximum_depth_and_depth_distribution_from_hand_histograms(square):
    histograms = [depth_row(b10=7), depth_row(b0=3, b255=3),
                  depth_row(b1=2, b2=2, b3=2, b4=2), depth_row()]
    data = view_data(square, [[7, 0], [3, 3], [4, 4], [0, 0]],
                     max_depth=[0.04, 1.0, 0.02, np.nan], depth_histogram=histograms)
    np.testing.assert_allclose(compute("MD", data), [0.04, 1.0, 0.02, np.nan])
    np.testing.assert_allclose(compute("DD", data), [0.0, 0.5, 0.75, np.nan])


def test_stoev_strasser_balances_normalised_area_against_depth(square):
    # a_t = 10, 20, 5, 0 pixels: p = 0.5, 1, 0.25, (none); SS = (1 + 2 min(p, d)) / 3.
    data = view_data(square, [[4, 6], [20, 0], [0, 5], [0, 0]],
                     max_depth=[0.8, 0.3, 1.0, np.nan])
    np.testing.assert_allclose(compute("SS", data), [2 / 3, 1.6 / 3, 1.5 / 3, np.nan])


def test_a_view_that_sees_nothing_is_nan_for_every_new_measure(cube):
    blank = view_data(cube, [[0] * cube.n_faces, [1] * cube.n_faces],
                      max_depth=[np.nan, 0.5], silhouette_length=[0.0, 10.0],
                      turning_histogram=[turning(), turning(a0=10)],
                      depth_histogram=[depth_row(), depth_row(b0=12)])
    for name in NEW_MEASURES:
        values = compute(name, blank)
        assert np.isnan(values[0]) and np.isfinite(values[1]), name


# --- curvature ----------------------------------------------------------------------------


def test_a_flat_grid_has_zero_curvature():
    np.testing.assert_array_equal(face_mean_curvature(grid_mesh(5)), 0.0)


@pytest.mark.parametrize("side", [1.0, 2.5], ids=["unit", "side-2.5"])
def test_every_cube_triangle_gets_pi_over_two_side_from_its_two_right_angle_edges(side):
    # Each triangle has two cube edges (dihedral pi / 2, density 3 pi / (4 side)) and a flat
    # diagonal: H = pi / (2 side), and sum A H = 12 edges * side * (pi / 2) / 2 = 3 pi side.
    cube = box_mesh((side, side, side))
    curvature = face_mean_curvature(cube)
    np.testing.assert_allclose(curvature, math.pi / (2 * side))
    assert face_areas(cube) @ curvature == pytest.approx(3 * math.pi * side)


def test_a_fine_sphere_has_nearly_uniform_curvature_one_over_radius():
    sphere = primitive_mesh("icosphere", {"subdivisions": 4, "radius": 2.0}, "sphere")
    curvature = face_mean_curvature(sphere)
    assert curvature.mean() == pytest.approx(0.5, rel=0.01)
    assert np.abs(curvature - 0.5).max() < 0.05
    # The integral of H over the sphere is 4 pi r.
    assert face_areas(sphere) @ curvature == pytest.approx(8 * math.pi, rel=0.01)


def test_reversing_the_winding_flips_the_sign():
    sphere = primitive_mesh("icosphere", {"subdivisions": 2, "radius": 1.0}, "sphere")
    inside_out = Mesh(sphere.vertices, sphere.faces[:, ::-1], "inside-out")
    np.testing.assert_allclose(face_mean_curvature(inside_out), -face_mean_curvature(sphere))


def test_boundary_non_manifold_and_inconsistent_edges_count_as_flat():
    # A tent: two triangles meeting at a 90-degree ridge along the y axis (convex, outward +z).
    vertices = np.array([[0.0, 0, 0], [0, 1, 0], [-1, 0, -1], [1, 0, -1], [0, 0, -2]])
    tent = Mesh(vertices, np.array([[0, 1, 2], [0, 3, 1]]), "tent")
    area = math.sqrt(2) / 2
    ridge = 1.0 * (math.pi / 2) / (2 * (2 * area / 3))
    np.testing.assert_allclose(face_mean_curvature(tent), ridge / 3)
    # A third face on the ridge makes it non-manifold; a flipped face makes it inconsistent.
    fin = Mesh(vertices, np.array([[0, 1, 2], [0, 3, 1], [0, 1, 4]]), "fin")
    flipped = Mesh(vertices, np.array([[0, 1, 2], [0, 1, 3]]), "flipped")
    np.testing.assert_array_equal(face_mean_curvature(fin), 0.0)
    np.testing.assert_array_equal(face_mean_curvature(flipped), 0.0)


def test_a_back_to_back_fold_counts_as_flat():
    # A triangle and its reverse on the same corners: every edge folds by exactly pi.
    triangle = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    fold = Mesh(triangle, np.array([[0, 1, 2], [0, 2, 1]]), "fold")
    np.testing.assert_array_equal(face_mean_curvature(fold), 0.0)


def test_a_triangle_soup_has_the_curvature_of_its_surface(cube):
    corners = cube.vertices[cube.faces].reshape(-1, 3)
    soup = Mesh(corners, np.arange(len(corners)).reshape(-1, 3), "soup")
    np.testing.assert_allclose(face_mean_curvature(soup), face_mean_curvature(cube))


def test_the_curvature_is_computed_once_per_mesh_cache(square):
    data = view_data(square, [[1, 1]])
    first = mesh_curvature(data)
    assert data.mesh_cache[CACHE_KEY] is first and mesh_curvature(data) is first


# --- curvature entropy --------------------------------------------------------------------


def test_curvature_entropy_weighs_faces_by_pixels_into_curvature_bins(cube):
    # The cube's faces all share one bin: 0 bits. A flat square beside it adds a second bin
    # (curvature 0): equal pixels in both give 1 bit, 3 : 1 gives H(1/4).
    square_vertices = np.array([[3.0, 0, 0], [4, 0, 0], [4, 1, 0], [3, 1, 0]])
    both = Mesh(np.concatenate([cube.vertices, square_vertices]),
                np.concatenate([cube.faces, np.array([[8, 9, 10], [8, 10, 11]])]), "both")
    bins = curvature_bins(view_data(both, [[1] * 14]))
    assert len(set(bins[:12])) == 1 and bins[12] == bins[13] == 127 and bins[0] != 127
    counts = np.zeros((4, 14), dtype=np.int64)
    counts[0, :12] = 5
    counts[1, [0, 12]] = 10
    counts[2, [0, 1, 13]] = [10, 20, 10]
    entropy_quarter = -(0.25 * math.log2(0.25) + 0.75 * math.log2(0.75))
    np.testing.assert_allclose(compute("CE", view_data(both, counts)),
                               [0.0, 1.0, entropy_quarter, np.nan], atol=1e-12)


def test_curvature_entropy_does_not_change_with_the_model_scale(bunny):
    small = Mesh(bunny.vertices * 1e-3, bunny.faces, "small")
    counts = np.ones((1, bunny.n_faces), dtype=np.int64)
    np.testing.assert_array_equal(curvature_bins(view_data(bunny, counts)),
                                  curvature_bins(view_data(small, counts)))


def test_curvature_entropy_of_a_sphere_is_nearly_the_same_from_every_view():
    sphere = primitive_mesh("icosphere", {"subdivisions": 3, "radius": 1.0}, "sphere")
    settings = MeasureSettings(views=24, resolution=96)
    directions = settings.directions()
    runs = list(iter_view_histograms(sphere, settings))
    data = ViewData(sphere, directions, settings, face_areas(sphere), runs)
    entropy = compute("CE", data)
    assert np.isfinite(entropy).all()
    assert entropy.max() - entropy.min() < 0.25
