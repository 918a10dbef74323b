"""The saliency measures SAL, EVMI and MS and the per-face saliencies they read.

The polygonal saliency is checked against a divergence worked out by hand on
two faces and against a direct, face-by-face computation on a drawn sphere;
its shape on a sphere (nearly uniform) and a box (high along the edges).
Lee et al.'s mesh saliency is checked on a box, where it is zero away from
the edges, and for not depending on the model's scale.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fixtures.meshes import box_mesh, primitive_mesh
from vptoolkit.geometry import face_areas, face_normals
from vptoolkit.measures.catalog._paper import paper_column
from vptoolkit.measures.curvature import face_mean_curvature
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.registry import get_measure, resolve_measures
from vptoolkit.measures.saliency import (
    CACHE_KEY,
    face_neighbours,
    lee_saliency,
    mesh_saliency,
    polygon_saliency,
)
from vptoolkit.mesh import Mesh
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.visibility import ViewHistograms, iter_view_histograms

SALIENCY_MEASURES = ("SAL", "EVMI", "MS")


def drawn(mesh: Mesh, views: int = 100, resolution: int = 64,
          directions: np.ndarray | None = None) -> ViewData:
    """A ViewData of the mesh drawn from Fibonacci-sphere views (or the directions given)."""
    settings = MeasureSettings(views=views if directions is None else len(directions),
                               resolution=resolution)
    if directions is None:
        directions = settings.directions()
    runs = list(iter_view_histograms(mesh, settings, view_directions=directions))
    return ViewData(mesh, directions, settings, face_areas(mesh), runs)


def hand_made(mesh: Mesh, counts: list[list[int]]) -> ViewData:
    """A ViewData of hand-made dense pixel counts ``(n_views, n_faces)`` in one run."""
    dense = np.asarray(counts, dtype=np.int64)
    rows, faces = np.nonzero(dense)
    offsets = np.concatenate([[0], np.cumsum(np.count_nonzero(dense, axis=1))])
    run = ViewHistograms(offsets.astype(np.int64), faces.astype(np.int32),
                         dense[rows, faces].astype(np.int32), mesh.n_faces)
    settings = MeasureSettings(views=len(dense), resolution=64)
    return ViewData(mesh, fibonacci_sphere(len(dense)), settings, face_areas(mesh), [run])


def dense_counts(data: ViewData) -> np.ndarray:
    views, faces, counts = data.entries
    dense = np.zeros((data.n_views, data.n_faces))
    dense[views, faces] = counts
    return dense


def soup(mesh: Mesh) -> Mesh:
    """The same triangles with no vertex shared, as an STL file holds them."""
    return Mesh(mesh.vertices[mesh.faces].reshape(-1, 3),
                np.arange(3 * mesh.n_faces).reshape(-1, 3), f"{mesh.name}-soup")


def subdivided_box(times: int) -> Mesh:
    import trimesh

    box = trimesh.creation.box()
    for _ in range(times):
        box = box.subdivide()
    return Mesh(box.vertices, box.faces, "box")


def entropy(weights: np.ndarray) -> float:
    p = weights[weights > 0] / weights.sum()
    return float(-(p * np.log2(p)).sum())


@pytest.fixture(scope="module")
def square() -> Mesh:
    """Two triangles making the unit square in z = 0, sharing the diagonal (0, 2)."""
    return Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]),
                np.array([[0, 1, 2], [0, 2, 3]]), "square")


@pytest.fixture(scope="module")
def sphere_views() -> ViewData:
    return drawn(primitive_mesh("icosphere", {"subdivisions": 1}, "sphere"))


# --- registry ------------------------------------------------------------------------------


def test_the_saliency_measures_follow_curvature_entropy_in_the_surface_family():
    expected = {"SAL": (1, True, {"pixels", "saliency"}),
                "EVMI": (2, False, {"pixels", "saliency"}),
                "MS": (3, True, {"pixels", "saliency", "curvature"})}
    surface = [name for name in resolve_measures("all") if get_measure(name).family == "surface"]
    for name, (place, higher_is_better, needs) in expected.items():
        measure = get_measure(name)
        assert (measure.family, surface.index(name), measure.higher_is_better,
                set(measure.needs)) == ("surface", place, higher_is_better, needs)
    assert surface[-3:] == list(SALIENCY_MEASURES)


# --- face neighbours -----------------------------------------------------------------------


def test_each_face_of_a_box_has_three_edge_neighbours_also_as_a_triangle_soup():
    box = box_mesh()
    pairs = face_neighbours(box)
    assert pairs.shape == (18, 2) and (pairs[:, 0] < pairs[:, 1]).all()
    assert np.bincount(pairs.ravel(), minlength=12).tolist() == [3] * 12
    shared_corners = [len(set(box.faces[a]) & set(box.faces[b])) for a, b in pairs]
    assert shared_corners == [2] * 18
    assert np.array_equal(face_neighbours(soup(box)), pairs)


def test_faces_meeting_at_a_vertex_only_are_not_neighbours():
    fan = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]]),
               np.array([[0, 1, 2], [0, 3, 4]]), "bow-tie")
    assert face_neighbours(fan).shape == (0, 2)


def test_three_faces_on_one_edge_are_each_others_neighbours():
    fin = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]]),
               np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]), "fin")
    assert face_neighbours(fin).tolist() == [[0, 1], [0, 2], [1, 2]]


# --- polygonal saliency and the measures on counts worked out by hand ----------------------


def test_two_faces_have_the_jensen_shannon_divergence_worked_out_by_hand(square):
    # View 0 sees both faces with 2 pixels each, view 1 face 0 with 4, view 2 nothing.
    data = hand_made(square, [[2, 2], [4, 0], [0, 0]])
    # p(V|0) = (1/3, 2/3, 0), p(V|1) = (1, 0, 0), weights 6/8 and 2/8, mixture (1/2, 1/2, 0).
    divergence = 1.0 - 0.75 * entropy(np.array([1.0, 2.0]))
    np.testing.assert_allclose(polygon_saliency(data), [divergence, divergence], rtol=1e-12)
    sal = get_measure("SAL").compute(data)
    np.testing.assert_allclose(sal[:2], [(1 / 3 + 1) * divergence, 2 / 3 * divergence],
                               rtol=1e-12)
    # Equal saliencies: p'(z) = p(z) = (3/4, 1/4), so EVMI is VMI.
    evmi = get_measure("EVMI").compute(data)
    np.testing.assert_allclose(evmi[:2], [0.5 * math.log2(2 / 3) + 0.5, math.log2(4 / 3)],
                               rtol=1e-12)
    assert np.isnan(sal[2]) and np.isnan(evmi[2])


def test_a_face_without_seen_neighbours_gets_the_lowest_for_sal_and_the_highest_for_evmi():
    # A strip of three faces 0-1-2 and face 3 apart from them.
    strip = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 1, 0],
                           [5, 5, 0], [6, 5, 0], [5, 6, 0]]),
                 np.array([[0, 1, 2], [1, 3, 2], [1, 4, 3], [5, 6, 7]]), "strip")
    assert face_neighbours(strip).tolist() == [[0, 1], [1, 2]]
    counts = [[3, 1, 2, 0], [1, 4, 0, 0], [0, 1, 5, 2], [0, 0, 0, 6], [0, 0, 0, 0]]
    data = hand_made(strip, counts)
    raw = polygon_saliency(data)
    assert np.isnan(raw[3]) and np.isfinite(raw[:3]).all()
    assert raw[1] == pytest.approx((raw[0] + raw[2]) / 2)
    lowest = polygon_saliency(data, undefined="lowest")
    highest = polygon_saliency(data, undefined="highest")
    assert lowest[3] == raw[:3].min() and highest[3] == raw[:3].max()

    dense = np.asarray(counts, dtype=np.float64)
    totals = dense.sum(axis=0)
    seen = dense.sum(axis=1) > 0
    expected_sal = (dense / totals) @ lowest
    p_view = dense[seen] / dense[seen].sum(axis=1, keepdims=True)
    p_salient = highest * totals / (highest * totals).sum()
    logs = np.log2(np.divide(p_view, p_salient, out=np.ones_like(p_view), where=p_view > 0))
    sal, evmi = get_measure("SAL").compute(data), get_measure("EVMI").compute(data)
    np.testing.assert_allclose(sal[seen], expected_sal[seen], rtol=1e-12)
    np.testing.assert_allclose(evmi[seen], (p_view * logs).sum(axis=1), rtol=1e-12, atol=1e-15)
    assert np.isnan(sal[~seen]).all() and np.isnan(evmi[~seen]).all()


# --- polygonal saliency on drawn meshes ----------------------------------------------------


def test_polygonal_saliency_matches_a_face_by_face_computation(sphere_views):
    data = sphere_views
    mesh, dense = data.mesh, dense_counts(data)
    totals = dense.sum(axis=0)
    neighbours: dict[int, set[int]] = {face: set() for face in range(mesh.n_faces)}
    for face, corners in enumerate(mesh.faces):
        for other, theirs in enumerate(mesh.faces):
            if other != face and len(set(corners) & set(theirs)) == 2:
                neighbours[face].add(other)
    expected = np.full(mesh.n_faces, np.nan)
    for face in range(mesh.n_faces):
        divergences = []
        for other in sorted(neighbours[face]):
            if totals[face] == 0 or totals[other] == 0:
                continue
            weight = totals[face] / (totals[face] + totals[other])
            divergences.append(entropy(dense[:, face] + dense[:, other])
                               - weight * entropy(dense[:, face])
                               - (1 - weight) * entropy(dense[:, other]))
        if divergences:
            expected[face] = np.mean(divergences)
    np.testing.assert_allclose(polygon_saliency(data), expected, rtol=1e-9, atol=1e-12)


def test_a_triangle_soup_has_the_saliency_of_its_indexed_mesh(sphere_views):
    again = drawn(soup(sphere_views.mesh))
    assert np.array_equal(polygon_saliency(again), polygon_saliency(sphere_views))


def test_a_sphere_has_nearly_uniform_saliency():
    data = drawn(primitive_mesh("icosphere", {"subdivisions": 3}, "sphere"),
                 views=200, resolution=128)
    saliency = polygon_saliency(data)
    assert np.isfinite(saliency).all()
    assert saliency.std() < 0.25 * saliency.mean()
    assert saliency.max() < 3 * saliency.min()


def test_a_box_is_salient_along_its_edges():
    box = subdivided_box(3)
    saliency = polygon_saliency(drawn(box, views=200, resolution=128))
    pairs = face_neighbours(box)
    normals = face_normals(box)
    bent = np.zeros(box.n_faces, dtype=bool)
    across = ~np.isclose(np.einsum("ij,ij->i", normals[pairs[:, 0]], normals[pairs[:, 1]]), 1.0)
    bent[pairs[across].ravel()] = True
    assert 0 < bent.sum() < box.n_faces // 4  # the triangles along the 12 edges
    assert saliency[bent].mean() > 5 * saliency[~bent].mean()


# --- SAL and EVMI on drawn meshes ----------------------------------------------------------


def test_evmi_is_vmi_when_every_face_is_equally_salient(sphere_views):
    data = drawn(sphere_views.mesh)
    data.cache[CACHE_KEY] = np.full(data.n_faces, 0.25)
    np.testing.assert_allclose(get_measure("EVMI").compute(data), paper_column(data, "VMI"),
                               rtol=1e-9)


def test_the_measures_are_finite_for_seen_views_and_repeat_to_the_bit():
    from vptoolkit.io import load_mesh
    from vptoolkit.samples import sample_path

    mesh = load_mesh(sample_path("lego.obj"))
    first, second = drawn(mesh), drawn(mesh)
    for name in SALIENCY_MEASURES:
        values = get_measure(name).compute(first)
        assert values.shape == (100,) and values.dtype == np.float64
        assert np.isfinite(values).all(), name
        assert values.tobytes() == get_measure(name).compute(second).tobytes(), name
    assert polygon_saliency(first) is first.cache[CACHE_KEY]


# --- Lee et al.'s mesh saliency and MS -----------------------------------------------------


def test_lee_saliency_of_a_box_is_zero_away_from_its_edges():
    box = subdivided_box(3)
    curvature = face_mean_curvature(box)
    saliency = lee_saliency(box, curvature)
    centroids = box.vertices[box.faces].mean(axis=1)
    # The widest Gaussian reaches 2 * 12 * 0.3 % of the diagonal, 0.125 on this box: faces
    # whose centroid is farther than that from every face of non-zero curvature see none.
    curved = centroids[curvature != 0]
    distance = np.linalg.norm(centroids[:, None] - curved[None], axis=2).min(axis=1)
    far = distance > 0.125 + 1e-9
    assert far.sum() > 0 and (saliency[far] == 0).all()
    assert (saliency[curvature != 0] > 0).all()
    assert saliency.max() <= len((2, 3, 4, 5, 6))


def test_lee_saliency_does_not_depend_on_the_scale_or_position():
    mesh = primitive_mesh("capsule", {"height": 1.0, "radius": 0.4, "count": [16, 16]}, "capsule")
    saliency = lee_saliency(mesh, face_mean_curvature(mesh))
    moved = Mesh(mesh.vertices * 10.0 + 3.0, mesh.faces, "moved")
    np.testing.assert_allclose(lee_saliency(moved, face_mean_curvature(moved)), saliency,
                               atol=1e-9)
    assert saliency.max() > 0


def test_ms_sums_the_saliency_of_the_seen_faces_and_is_nan_for_a_view_that_sees_nothing():
    box = box_mesh()
    counts = [[5, 5, 0, 0, 3, 0, 0, 0, 0, 0, 0, 0], [0] * 12, [1] * 12]
    data = hand_made(box, counts)
    saliency = mesh_saliency(data)
    seen = np.asarray(counts) > 0
    values = get_measure("MS").compute(data)
    np.testing.assert_allclose(values[[0, 2]], (seen @ saliency)[[0, 2]], rtol=1e-12)
    assert np.isnan(values[1])


def test_ms_prefers_a_view_of_a_box_corner_to_a_view_of_one_side():
    corner = np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)
    data = drawn(subdivided_box(3), directions=np.array([[0.0, 0.0, 1.0], corner]))
    side, corner_value = get_measure("MS").compute(data)
    assert corner_value > 2 * side


def test_the_neighbours_of_points_are_the_nearest_pairs_each_once():
    from vptoolkit.measures.saliency import point_neighbours

    grid = np.stack(np.meshgrid(np.arange(5.0), np.arange(4.0), [0.0]), axis=-1).reshape(-1, 3)
    pairs = point_neighbours(grid, k=4)
    assert pairs.dtype == np.int64 and (pairs[:, 0] < pairs[:, 1]).all()
    assert len(np.unique(pairs, axis=0)) == len(pairs)
    lengths = np.linalg.norm(grid[pairs[:, 0]] - grid[pairs[:, 1]], axis=1)
    # each point's 4 nearest on a unit grid lie at distance 1 (inside), up to 2 (a corner)
    assert lengths.min() == 1.0 and lengths.max() <= 2.0
    edges = {tuple(pair) for pair in pairs.tolist()}
    assert all((i, i + 1) in edges for i in range(len(grid) - 1) if (i + 1) % 5)  # every row edge
