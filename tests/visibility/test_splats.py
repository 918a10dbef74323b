"""Splatted point visibility against the mesh rasteriser and Open3D's hidden point removal."""

import numpy as np
import pytest

from fixtures.environment import require_package
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.measures.sums import quality_from_histograms
from vptoolkit.points import sample_surface
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.visibility import RasterScene
from vptoolkit.visibility.splats import PointScene, iter_point_histograms

SAMPLES = ["bunny.ply", "torus.STL", "Duck.glb"]
"""Samples whose faces are small enough that a face seen is about the points on it seen."""


def _seen(histograms, n_views, n_items):
    seen = np.zeros((n_views, n_items), dtype=bool)
    for run in histograms:
        seen[run.view_index() + run.first_view, run.face_ids] = True
    return seen


def _cloud(name):
    mesh = load_mesh(sample_path(name))
    return mesh, sample_surface(mesh, 20000, seed=0)


@pytest.mark.parametrize("name", SAMPLES)
def test_points_seen_are_the_points_on_the_faces_seen(name):
    # At 1024 px a point's piece of surface covers a few pixels: nearly every
    # point the splats see lies on a face the rasteriser sees (precision), and
    # the two agree on seen or hidden for most points. At lower resolutions
    # precision holds, but points whose cell holds no pixel centre go unseen.
    mesh, sample = _cloud(name)
    directions = fibonacci_sphere(12)
    points = _seen(PointScene(sample.points, sample.normals).histograms(directions, 1024),
                   12, len(sample.points))
    faces = _seen(RasterScene(mesh).histograms(directions, 1024), 12, mesh.n_faces)
    on_seen_face = faces[:, sample.face_index]
    precision = (points & on_seen_face).sum(axis=1) / points.sum(axis=1)
    agreement = (points == on_seen_face).mean(axis=1)
    assert precision.min() > 0.95
    assert agreement.mean() > 0.93


@pytest.mark.parametrize("name", SAMPLES)
def test_points_seen_agree_with_hidden_point_removal(name):
    # Katz et al.'s hidden point removal decides by a convex hull after
    # spherical flipping, another method: agreement, not equality.
    require_package("open3d")
    import open3d as o3d

    _, sample = _cloud(name)
    directions = fibonacci_sphere(12)
    scene = PointScene(sample.points, sample.normals)
    points = _seen(scene.histograms(directions, 1024), 12, len(sample.points))
    poses = scene.camera.poses(directions, centre=scene.centre, diagonal=scene.diagonal,
                               resolution=1024)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(sample.points))
    agreement = []
    for view in range(12):
        _, kept = cloud.hidden_point_removal(poses.eyes[view], 100.0 * scene.diagonal)
        removal = np.zeros(len(sample.points), dtype=bool)
        removal[kept] = True
        agreement.append((points[view] == removal).mean())
    assert np.mean(agreement) > 0.88


def test_pixels_of_a_view_match_the_mesh_outline():
    # The splats cover about the pixels the mesh covers: the outline grows by
    # about two spacings, and the holes between splats are few.
    mesh, sample = _cloud("bunny.ply")
    directions = fibonacci_sphere(8)
    points = np.concatenate([run.to_dense() for run in PointScene(
        sample.points, sample.normals).histograms(directions, 256)]).sum(axis=1)
    faces = np.concatenate([run.to_dense() for run in RasterScene(mesh).histograms(
        directions, 256)]).sum(axis=1)
    np.testing.assert_allclose(points, faces, rtol=0.12)


def test_normals_cull_the_points_that_face_away():
    # a flat square seen from its back: culled with normals, drawn as balls without
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.random((2000, 2)), np.zeros(2000)])
    normals = np.tile([0.0, 0.0, 1.0], (2000, 1))
    front, back = [[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]]
    with_normals = PointScene(points, normals)
    assert next(with_normals.histograms(front, 64)).pixel_counts.sum() > 0
    assert next(with_normals.histograms(back, 64)).pixel_counts.sum() == 0
    assert next(PointScene(points).histograms(back, 64)).pixel_counts.sum() > 0


def test_histograms_are_those_of_the_scene_whatever_the_batching():
    _, sample = _cloud("torus.STL")
    settings = MeasureSettings(views=40, resolution=96)
    whole = np.concatenate([run.to_dense() for run in iter_point_histograms(
        sample.points, settings, normals=sample.normals)])
    scene = PointScene(sample.points, sample.normals)
    one_by_one = np.concatenate([run.to_dense() for direction in settings.directions()
                                 for run in scene.histograms([direction], 96)])
    np.testing.assert_array_equal(whole, one_by_one)


@pytest.mark.parametrize(("arguments", "message"), [
    ({"normals": np.zeros((5, 3))}, r"normals: expected shape \(20000, 3\)"),
    ({"normals": np.zeros((20000, 3))}, "normals: values must be finite and of non-zero"),
    ({"thickness": 0.0}, r"thickness: expected a number in \(0, 1\]"),
    ({"splat_scale": -1.0}, "splat_scale: expected a positive number"),
])
def test_bad_arguments_give_one_line(arguments, message):
    _, sample = _cloud("torus.STL")
    with pytest.raises(InputError, match=message):
        PointScene(sample.points, **arguments)


@pytest.mark.slow
@pytest.mark.parametrize("name", SAMPLES)
def test_point_measures_rank_the_views_as_the_mesh_measures(name):
    # The paper's measures from the points' pixels and areas against the
    # mesh's, over 1000 views at 256 px. VE depends on how finely the surface
    # is cut (faces against points), so it has no bound here.
    from scipy.stats import spearmanr

    mesh, sample = _cloud(name)
    directions = fibonacci_sphere(1000)
    scene = RasterScene(mesh)
    on_mesh = quality_from_histograms(scene.histograms(directions, 256), scene.areas,
                                      n_views=1000)
    cloud = PointScene(sample.points, sample.normals)
    on_points = quality_from_histograms(cloud.histograms(directions, 256), cloud.areas,
                                        n_views=1000)
    for column in (1, 2, 3):  # VR, VKL, VMI
        assert spearmanr(on_mesh[:, column], on_points[:, column])[0] >= 0.9
