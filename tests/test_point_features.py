"""Tests of vptoolkit.point_features: the face-area and normal features, how features turn,
and the face under a stored point."""

from __future__ import annotations

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.meshes import box_mesh, primitive_mesh
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.mesh import Mesh
from vptoolkit.point_features import (
    CLOUD_FEATURES,
    FACE_AREA_CLIP,
    FACE_FEATURES,
    FEATURE_WIDTHS,
    POINT_FEATURES,
    check_feature_names,
    face_area_feature,
    feature_width,
    locate_faces,
    normal_feature,
    point_features,
    spacing_area_feature,
    turn_features,
)
from vptoolkit.points import sample_surface
from vptoolkit.rotations import random_rotation
from vptoolkit.samples import sample_path

# Three tessellations: the bunny's 16k faces, welded, with some faces stored twice (both
# windings); the torus's 8.7k faces of unwelded vertices (an STL); the teapot's 894 faces
# of very different sizes.
SAMPLES = ("bunny.ply", "torus.STL", "teapot.stl")


def square() -> Mesh:
    """The docstring's 2 x 2 square: faces of areas 1, 1 and 2 (their mean 4/3)."""
    vertices = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0], [1, 1, 0]], float)
    return Mesh(vertices, np.array([[0, 1, 4], [1, 2, 4], [2, 3, 0]]), "square")


def on_faces(mesh: Mesh, index) -> dict:
    """``point_features``'s arguments for points at the centroids of the faces ``index``."""
    index = np.asarray(index)
    return {"points": mesh.vertices[mesh.faces[index]].mean(axis=1), "mesh": mesh,
            "face_index": index}


def face_areas(mesh: Mesh) -> np.ndarray:
    """Face areas in float64, half the norm of the edge cross product."""
    corners = mesh.vertices[mesh.faces]
    return 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                         corners[:, 2] - corners[:, 0]), axis=1)


def diagonal(mesh: Mesh) -> float:
    return float(np.linalg.norm(mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)))


def distances(mesh: Mesh, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance from each point to its face: to the face's plane where the point's foot on it
    lies inside the face, else to the nearest of the face's three edges (zero-area faces have
    no plane, only edges). Written out here, since trimesh's closest points stray by 1e-4 of
    the bunny's size on its slivers."""
    a, b, c = np.moveaxis(mesh.vertices[mesh.faces[faces]], 1, 0)
    normal = np.cross(b - a, c - a)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = normal / np.linalg.norm(normal, axis=1, keepdims=True)
        height = np.einsum("ij,ij->i", points - a, unit)
        foot = points - height[:, None] * unit
        inside = np.ones(len(points), bool)
        edges = np.full(len(points), np.inf)
        for start, end in ((a, b), (b, c), (c, a)):
            inside &= np.einsum("ij,ij->i", np.cross(end - start, foot - start), normal) >= 0
            along = end - start
            length = np.einsum("ij,ij->i", along, along)
            share = np.clip(np.einsum("ij,ij->i", points - start, along) / length, 0.0, 1.0)
            share[length == 0] = 0.0
            edges = np.minimum(edges, np.linalg.norm(points - start - share[:, None] * along,
                                                     axis=1))
    return np.where(inside, np.abs(height), edges)


@pytest.fixture()
def kernel() -> None:
    """locate_faces runs a numba kernel; trimesh makes the boxes and spheres."""
    require_package("numba")
    require_package("trimesh")


# face_area_feature


def test_the_docstring_square_by_hand():
    feature = face_area_feature(square(), np.array([0, 1, 2, 0]))
    assert feature.dtype == np.float32 and feature.shape == (4,)
    small, large = np.log(1 / (4 / 3)) / 2, np.log(2 / (4 / 3)) / 2  # ln(A_f / A_mean) / 2
    np.testing.assert_allclose(feature, [small, small, large, small], rtol=1e-6)
    # the docstring's values (rounded in float64: float32's 0.144 prints as 0.14399999...)
    assert feature.astype(np.float64).round(3).tolist() == [-0.144, -0.144, 0.203, -0.144]
    assert face_area_feature(square(), [2]).tolist() == feature[2:3].tolist()  # a list is read too


def test_a_mesh_of_equal_faces_is_zero_everywhere():
    cube = box_mesh()
    assert len(cube.faces) == 12 and np.allclose(face_areas(cube), 0.5)
    np.testing.assert_array_equal(face_area_feature(cube, np.arange(12)), np.zeros(12))


def test_moving_turning_and_scaling_the_mesh_changes_nothing(bunny):
    index = np.arange(len(bunny.faces))
    feature = face_area_feature(bunny, index)
    assert feature.std() > 0.2  # the bunny's faces differ, so the comparison means something
    rotation = random_rotation(np.random.default_rng(4))
    moved = Mesh(7.3 * bunny.vertices @ rotation.T + [10.0, -4.0, 2.5], bunny.faces, "moved")
    np.testing.assert_allclose(face_area_feature(moved, index), feature, atol=1e-5)
    shrunk = Mesh(1e-3 * bunny.vertices, bunny.faces, "shrunk")
    np.testing.assert_allclose(face_area_feature(shrunk, index), feature, atol=1e-5)


def test_the_feature_is_clipped_at_three():
    """One face of area 5e5, one of 5000 and 999 of 5e-7: the mean is about 504.5, so the
    large face's ln(A / A_mean) / 2 is 3.45 and the tiny ones' -6.9, both clipped; the
    5000 face's 1.15 is not."""
    vertices = [[0.0, 0, 0], [1000, 0, 0], [0, 1000, 0], [0, 0, 5], [100, 0, 5], [0, 100, 5]]
    faces = [[0, 1, 2], [3, 4, 5]]
    for i in range(999):
        corner = np.array([i * 0.01, 0.0, 10.0])
        faces.append([len(vertices), len(vertices) + 1, len(vertices) + 2])
        vertices += [corner, corner + [1e-3, 0, 0], corner + [0, 1e-3, 0]]
    mesh = Mesh(np.array(vertices), np.array(faces), "uneven")
    feature = face_area_feature(mesh, np.arange(len(faces)))
    assert feature[0] == FACE_AREA_CLIP == 3.0
    assert (feature[2:] == -FACE_AREA_CLIP).all()
    areas = face_areas(mesh)
    unclipped = np.log(areas[1] / areas.mean()) / 2
    assert 1.1 < unclipped < 1.2 and feature[1] == pytest.approx(unclipped, rel=1e-6)


def test_a_face_of_zero_area_gets_minus_three():
    flat = square()
    vertices = np.vstack([flat.vertices, [[1.0, 0.0, 0.0]]])  # on the edge from 0 to 1
    faces = np.vstack([flat.faces, [[0, 5, 1]]])  # its three corners on one line
    mesh = Mesh(vertices, faces, "with_sliver")
    feature = face_area_feature(mesh, np.arange(4))
    assert feature[3] == -3.0
    np.testing.assert_allclose(feature[:3], np.log([1.0, 1.0, 2.0]) / 2, atol=1e-7)  # mean 1


@pytest.mark.parametrize("index, problem", [
    (np.array([0, 3]), "expected indices in [0, 3), got 0 to 3"),
    (np.array([-1, 2]), "expected indices in [0, 3), got -1 to 2"),
    (np.array([[0, 1]]), "expected a 1-d integer array, got int64 of shape (1, 2)"),
    (np.array([0.0, 1.0]), "expected a 1-d integer array, got float64 of shape (2,)"),
])
def test_a_bad_face_index_is_refused_in_one_line_naming_the_mesh(index, problem):
    with pytest.raises(InputError) as info:
        face_area_feature(square(), index)
    message = str(info.value)
    assert message.startswith("square: face_index: ") and problem in message
    assert "\n" not in message


def test_a_mesh_of_zero_area_is_refused():
    line = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]]), "line")
    with pytest.raises(InputError, match="^line: mesh has zero surface area"):
        face_area_feature(line, [0])


# check_feature_names and point_features


@pytest.mark.parametrize("names, problem", [
    (["curvature"], "unknown ['curvature']"),
    (["face_area", "face_area"], "names a feature twice"),
    ("face_area", "expected a list of names"),
    ([1], "expected a list of names"),
    (None, "expected a list of names"),
])
def test_bad_feature_names_are_refused(names, problem):
    with pytest.raises(InputError, match="^point_features: ") as info:
        check_feature_names(names)
    assert problem in str(info.value)


@pytest.mark.parametrize("names", [["curvature"], ["face_area", "face_area"], "face_area"])
def test_point_features_refuses_bad_names(names):
    with pytest.raises(InputError, match="^point_features: "):
        point_features(names=names, **on_faces(square(), np.array([0, 1])))


def test_good_names_come_back_as_a_tuple():
    assert check_feature_names(["face_area"]) == ("face_area",)
    assert check_feature_names(()) == ()
    assert check_feature_names(list(POINT_FEATURES)) == POINT_FEATURES


def test_names_read_from_a_command_line():
    assert check_feature_names("face_area, normal", text=True) == ("face_area", "normal")
    assert check_feature_names("none", text=True) == ()
    with pytest.raises(InputError, match=r"^point_features: unknown \['none'\]"):
        check_feature_names("face_area,none", text=True)
    with pytest.raises(InputError, match="expected a list of names"):
        check_feature_names("face_area")  # a string only where a command line gives one


def test_no_names_give_an_empty_float32_block():
    features = point_features(names=(), **on_faces(square(), np.array([0, 2, 1])))
    assert features.shape == (3, 0) and features.dtype == np.float32


def test_the_columns_follow_the_names():
    index = np.array([2, 0, 1, 2])
    features = point_features(names=["face_area"], **on_faces(square(), index))
    assert features.shape == (4, 1) and features.dtype == np.float32
    np.testing.assert_array_equal(features[:, 0], face_area_feature(square(), index))
    assert feature_width(POINT_FEATURES) == sum(FEATURE_WIDTHS.values()) == 8
    for order in (FACE_FEATURES, FACE_FEATURES[::-1]):
        every = point_features(names=order, **on_faces(square(), index))
        assert every.shape == (4, feature_width(order)) and every.dtype == np.float32
        start = 0
        for name in order:
            alone = point_features(names=[name], **on_faces(square(), index))
            np.testing.assert_array_equal(every[:, start:start + FEATURE_WIDTHS[name]], alone)
            start += FEATURE_WIDTHS[name]


# normal_feature and turn_features


def test_normals_are_the_sampled_faces_normals(bunny):
    sample = sample_surface(bunny, 5000, seed=3)
    normals = normal_feature(bunny, sample.face_index)
    assert normals.shape == (5000, 3) and normals.dtype == np.float32
    np.testing.assert_allclose(normals, sample.normals, atol=1e-6)


def test_normals_follow_the_winding_and_a_degenerate_face_gets_zero():
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], float)
    mesh = Mesh(vertices, np.array([[0, 1, 2], [0, 2, 1], [0, 1, 3]]), "flat")
    np.testing.assert_array_equal(normal_feature(mesh, [0, 1, 2]),
                                  [[0, 0, 1], [0, 0, -1], [0, 0, 0]])


def test_normals_turn_with_the_mesh_and_ignore_moving_and_scaling(bunny):
    index = sample_surface(bunny, 2000, seed=0).face_index
    rotation = random_rotation(np.random.default_rng(8))
    turned = Mesh(3.0 * bunny.vertices @ rotation.T + 5.0, bunny.faces, "turned")
    np.testing.assert_allclose(normal_feature(turned, index),
                               normal_feature(bunny, index) @ rotation.T, atol=1e-5)
    features = point_features(names=POINT_FEATURES, **on_faces(bunny, index))
    np.testing.assert_allclose(point_features(names=POINT_FEATURES, **on_faces(turned, index)),
                               turn_features(features, POINT_FEATURES, rotation.T), atol=1e-5)


def test_turning_features_turns_vectors_and_keeps_numbers():
    rotation = random_rotation(np.random.default_rng(2))
    features = np.random.default_rng(0).normal(size=(6, 4)).astype(np.float32)
    turned = turn_features(features, ["face_area", "normal"], rotation.T)
    assert turned.dtype == np.float32 and turned is not features
    np.testing.assert_array_equal(turned[:, 0], features[:, 0])
    np.testing.assert_allclose(turned[:, 1:], features[:, 1:] @ rotation.T, rtol=1e-6)
    backwards = turn_features(features[:, [1, 2, 3, 0]], ["normal", "face_area"], rotation.T)
    np.testing.assert_allclose(backwards[:, [3, 0, 1, 2]], turned, rtol=1e-6)
    numbers = features[:, :1]
    assert turn_features(numbers, ["face_area"], rotation.T) is numbers  # nothing to turn


def test_turning_torch_features_one_turn_per_cloud():
    torch = pytest.importorskip("torch")
    turns = np.stack([random_rotation(np.random.default_rng(seed)) for seed in range(3)])
    features = np.random.default_rng(1).normal(size=(3, 5, 4))
    turned = turn_features(torch.from_numpy(features), ["face_area", "normal"],
                           torch.from_numpy(turns))
    for cloud in range(3):
        np.testing.assert_allclose(turned[cloud].numpy(),
                                   turn_features(features[cloud], ["face_area", "normal"],
                                                 turns[cloud]))


# locate_faces


@pytest.mark.usefixtures("kernel")
@pytest.mark.parametrize("name", SAMPLES)
def test_float32_points_get_their_face_or_an_equal_face_they_lie_on(name):
    mesh = load_mesh(sample_path(name))
    sample = sample_surface(mesh, 5000, seed=5)
    rounded = sample.points.astype(np.float32).astype(np.float64)
    found = locate_faces(mesh, rounded)
    assert found.dtype == np.int64 and found.shape == (5000,)
    assert (found == sample.face_index).mean() > 0.99
    other = found != sample.face_index
    areas = face_areas(mesh)
    np.testing.assert_allclose(areas[found[other]], areas[sample.face_index[other]], rtol=1e-9)
    np.testing.assert_array_equal(face_area_feature(mesh, found),
                                  face_area_feature(mesh, sample.face_index))
    # every point lies on its located face, no farther than from the face it was drawn on
    gaps = distances(mesh, found, rounded)
    assert gaps.max() < 1e-6 * diagonal(mesh)
    assert (gaps <= distances(mesh, sample.face_index, rounded) + 1e-12 * diagonal(mesh)).all()


@pytest.mark.usefixtures("kernel")
@pytest.mark.parametrize("name", SAMPLES)
def test_exact_points_get_their_sampled_face(name):
    mesh = load_mesh(sample_path(name))
    sample = sample_surface(mesh, 5000, seed=6)
    found = locate_faces(mesh, sample.points)
    assert (found == sample.face_index).mean() > 0.99
    # the others are the same face stored again (the bunny's faces of both windings)
    other = found != sample.face_index
    np.testing.assert_array_equal(np.sort(mesh.faces[found[other]], axis=1),
                                  np.sort(mesh.faces[sample.face_index[other]], axis=1))


@pytest.mark.usefixtures("kernel")
def test_degenerate_faces_and_duplicated_vertices_are_never_located():
    """A 1 x 2 x 3 box of unwelded vertices (36, three per face) after three faces of zero
    area, which win ties by their lower index: a point at a corner, a sliver along an edge
    and a sliver along the diagonal that two faces of a side share."""
    box = box_mesh((1.0, 2.0, 3.0))
    corners = box.vertices[box.faces].reshape(-1, 3)
    a, b = box.vertices[box.faces[0, 0]], box.vertices[box.faces[0, 1]]
    c = box.vertices[box.faces[0, 2]]
    slivers = np.array([a, a, a, a, (a + b) / 2, b, b, (b + c) / 2, c])
    vertices = np.vstack([slivers, corners])
    faces = np.vstack([np.arange(9).reshape(3, 3), 9 + np.arange(36).reshape(12, 3)])
    mesh = Mesh(vertices, faces, "slivered_box")
    assert (face_areas(mesh)[:3] == 0).all() and (face_areas(mesh)[3:] > 0).all()
    sample = sample_surface(mesh, 5000, seed=7)
    for points in (sample.points, sample.points.astype(np.float32).astype(np.float64)):
        found = locate_faces(mesh, points)
        assert found.min() >= 3
        assert (found == sample.face_index).mean() > 0.99
        assert distances(mesh, found, points).max() < 1e-6


@pytest.mark.usefixtures("kernel")
def test_points_just_off_a_convex_surface_get_the_face_below_them():
    box = box_mesh((1.0, 2.0, 3.0))
    sample = sample_surface(box, 5000, seed=8)
    lifted = sample.points + 1e-3 * diagonal(box) * sample.normals
    np.testing.assert_array_equal(locate_faces(box, lifted), sample.face_index)


@pytest.mark.usefixtures("kernel")
def test_points_off_the_surface_get_their_nearest_face():
    sphere = primitive_mesh("icosphere", {"subdivisions": 2}, "icosphere")
    points = np.random.default_rng(0).uniform(-1.0, 1.0, (300, 3))
    found = locate_faces(sphere, points)
    every = np.stack([distances(sphere, np.full(len(points), face), points)
                      for face in range(len(sphere.faces))], axis=1)
    np.testing.assert_allclose(every[np.arange(len(points)), found], every.min(axis=1),
                               atol=1e-12)


@pytest.mark.usefixtures("kernel")
def test_no_points_give_no_faces(bunny):
    found = locate_faces(bunny, np.zeros((0, 3)))
    assert found.shape == (0,) and found.dtype == np.int64


@pytest.mark.usefixtures("kernel")
@pytest.mark.parametrize("points", [
    np.array([[0.0, np.nan, 0.0]]),
    np.array([[np.inf, 0.0, 0.0]]),
    np.zeros((4, 2)),
    np.zeros(3),
])
def test_bad_points_are_refused_naming_the_mesh(points):
    with pytest.raises(InputError,
                       match=r"^square: points: expected an \(n, 3\) array of finite numbers"):
        locate_faces(square(), points)


@pytest.mark.parametrize("names", [["normal"] * 5000, ["x" * 5000], "n" * 5000])
def test_a_huge_feature_list_is_echoed_cut_short(names):
    with pytest.raises(InputError) as raised:
        check_feature_names(names)
    assert len(str(raised.value)) < 200 and "..." in str(raised.value)


# the cloud features: from the points alone


def test_cloud_features_need_no_faces_and_follow_the_spacing(bunny):
    sample = sample_surface(bunny, 20000, seed=1)
    features = point_features(sample.points, CLOUD_FEATURES)
    assert features.shape == (20000, 4) and features.dtype == np.float32
    # an area-uniform sample: the spacing area is noise about 0 (spread about 1/sqrt(8) / 2)
    assert abs(float(np.median(features[:, 0]))) < 0.1
    assert 0.1 < float(features[:, 0].std()) < 0.3
    # estimated normals lie along the true ones, up to the sign the outward rule picks
    agreement = np.abs(np.sum(features[:, 1:] * sample.normals, axis=1))
    assert np.median(agreement) > 0.98
    np.testing.assert_allclose(np.linalg.norm(features[:, 1:], axis=1), 1.0, rtol=1e-5)


def test_a_denser_half_reads_a_smaller_spacing_area(bunny):
    points = sample_surface(bunny, 20000, seed=2).points
    left = points[:, 0] < np.median(points[:, 0])
    denser = np.concatenate([points[left], sample_surface(bunny, 60000, seed=3).points])
    denser = denser[denser[:, 0] < np.median(points[:, 0])]
    cloud = np.concatenate([denser, points[~left]])
    feature = spacing_area_feature(cloud)
    dense, sparse = feature[: len(denser)], feature[len(denser):]
    # about four times the points per area on the left: ln(4) / 2 = 0.69 apart
    assert 0.5 < float(np.median(sparse) - np.median(dense)) < 0.9


def test_cloud_features_turn_with_the_points_and_ignore_moving_and_scaling(bunny):
    points = sample_surface(bunny, 5000, seed=4).points
    rotation = random_rotation(np.random.default_rng(5))
    features = point_features(points, CLOUD_FEATURES)
    moved = point_features(2.5 * points @ rotation.T - 7.0, CLOUD_FEATURES)
    np.testing.assert_allclose(moved, turn_features(features, CLOUD_FEATURES, rotation.T),
                               atol=1e-4)


def test_face_features_of_bare_points_are_refused_in_one_line(bunny):
    points = sample_surface(bunny, 100, seed=0).points
    with pytest.raises(InputError, match=r"^point_features: face_area reads the faces under "
                                         r"the points, and these have none"):
        point_features(points, ["spacing_area", "face_area"])


def test_repeated_points_count_once_and_too_few_distinct_points_are_refused(bunny):
    points = sample_surface(bunny, 3000, seed=6).points
    repeated = np.concatenate([points, points[::3], points[::7]])
    features = point_features(repeated, CLOUD_FEATURES)
    np.testing.assert_allclose(features[:3000], point_features(points, CLOUD_FEATURES),
                               atol=1e-6)
    np.testing.assert_array_equal(features[3000:4000], features[:3000:3])
    with pytest.raises(InputError, match="^points: 8 distinct points, need more than 8"):
        spacing_area_feature(np.repeat(points[:8], 50, axis=0))
