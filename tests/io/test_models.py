"""io.load: one model type in, a Mesh or a PointCloud decided by content; the one surface check."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from vptoolkit.errors import InputError, MeshLoadError
from vptoolkit.inputs import open_inputs, read_model
from vptoolkit.io import load, load_mesh, require_surface
from vptoolkit.mesh import Mesh
from vptoolkit.point_cloud import PointCloud
from vptoolkit.points import sample_surface
from vptoolkit.samples import sample_path


def cloud_ply(path: Path, points: np.ndarray, normals: np.ndarray | None = None, *,
              binary: bool = True) -> Path:
    """A PLY of a vertex element alone (x y z, and nx ny nz when given)."""
    names = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals is not None else [])
    table = points if normals is None else np.concatenate([points, normals], axis=1)
    header = ("ply\nformat " + ("binary_little_endian" if binary else "ascii") + " 1.0\n"
              f"element vertex {len(points)}\n"
              + "".join(f"property float {name}\n" for name in names) + "end_header\n")
    if binary:
        body = table.astype("<f4").tobytes()
    else:
        body = "".join(" ".join(f"{value:.6f}" for value in row) + "\n"
                       for row in table).encode()
    path.write_bytes(header.encode() + body)
    return path


@pytest.fixture(scope="module")
def bunny_sample():
    return sample_surface(load_mesh(sample_path("bunny.ply")), 3000, seed=0)


@pytest.mark.parametrize("binary", [True, False], ids=["binary", "ascii"])
def test_a_ply_without_faces_is_a_point_cloud_with_its_normals(tmp_path, bunny_sample, binary):
    path = cloud_ply(tmp_path / "scan.ply", bunny_sample.points, bunny_sample.normals,
                     binary=binary)
    cloud = load(path)
    assert isinstance(cloud, PointCloud) and cloud.name == "scan"
    np.testing.assert_allclose(cloud.points, bunny_sample.points, atol=1e-6)
    assert cloud.normals is not None
    np.testing.assert_allclose(np.linalg.norm(cloud.normals, axis=1), 1.0)
    np.testing.assert_allclose(cloud.normals, bunny_sample.normals, atol=1e-5)


def test_every_sample_mesh_loads_as_the_same_mesh_through_load():
    for name in ("bunny.ply", "teapot.stl", "mug.obj", "ballA.off", "Duck.glb"):
        mesh = load(sample_path(name))
        assert isinstance(mesh, Mesh)
        same = load_mesh(sample_path(name))
        np.testing.assert_array_equal(mesh.vertices, same.vertices)
        np.testing.assert_array_equal(mesh.faces, same.faces)


def test_a_point_cloud_is_refused_with_one_message_where_a_surface_is_needed(tmp_path,
                                                                             bunny_sample):
    path = cloud_ply(tmp_path / "scan.ply", bunny_sample.points)
    message = r"^scan\.ply: a point cloud \(3000 points, no faces\); this needs a surface"
    with pytest.raises(MeshLoadError, match=message):
        load_mesh(path)
    with pytest.raises(MeshLoadError, match=message):
        read_model(path, requires="surface")
    assert isinstance(read_model(path), PointCloud)
    mug = tmp_path / "mug.obj"
    mug.write_bytes(sample_path("mug.obj").read_bytes())
    with open_inputs([path, mug], requires="surface") as sources:
        assert [source.kind for source in sources] == ["file", "file"]
        with pytest.raises(MeshLoadError, match=message):
            sources[0].model()
        assert sources[1].mesh().name == "mug"
    with open_inputs(path) as sources:  # without requires: the points, as they are
        np.testing.assert_allclose(sources[0].points(seed=0), bunny_sample.points, atol=1e-6)
        with pytest.raises(MeshLoadError, match=message):
            sources[0].mesh()


def test_require_surface_returns_a_mesh_as_it_is():
    mesh = load_mesh(sample_path("teapot.stl"))
    assert require_surface(mesh) is mesh


def test_a_command_that_needs_a_surface_refuses_a_point_cloud_in_one_line(tmp_path, bunny_sample,
                                                                          runner):
    from vptoolkit.cli import main

    path = cloud_ply(tmp_path / "scan.ply", bunny_sample.points)
    out = tmp_path / "out.npy"
    result = runner.invoke(main, ["sample", str(path), "-o", str(out)])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1
    assert "scan.ply: a point cloud (3000 points, no faces); this needs a surface" in result.stderr
    assert not out.exists()


def test_arrays_and_tuples_become_point_clouds_and_meshes(bunny_sample):
    cloud = load(bunny_sample.points, name="scan")
    assert isinstance(cloud, PointCloud) and cloud.normals is None and cloud.name == "scan"
    with_normals = load(np.concatenate([bunny_sample.points, 3 * bunny_sample.normals], axis=1))
    np.testing.assert_allclose(with_normals.normals, bunny_sample.normals)
    mesh = load_mesh(sample_path("mug.obj"))
    assert isinstance(load((mesh.vertices, mesh.faces)), Mesh)
    assert load(mesh) is mesh and load(cloud) is cloud
    with pytest.raises(InputError, match=r"expected an \(N, 3\) or \(N, 6\) point array"):
        load(np.zeros((4, 4)))
    with pytest.raises(InputError, match="got dict"):
        load({})


def test_trimesh_meshes_point_clouds_and_scenes_are_read():
    require_package("trimesh")
    import trimesh

    mesh = load_mesh(sample_path("mug.obj"))
    loaded = load(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False), name="mug")
    assert isinstance(loaded, Mesh)
    np.testing.assert_array_equal(loaded.faces, mesh.faces)
    cloud = load(trimesh.PointCloud(mesh.vertices))
    assert isinstance(cloud, PointCloud) and cloud.n_points == mesh.n_vertices
    scene = trimesh.load_scene(str(sample_path("Duck.glb")))
    from_scene = load(scene, name="Duck")
    duck = load_mesh(sample_path("Duck.glb"))  # node transforms applied alike
    np.testing.assert_allclose(from_scene.vertices, duck.vertices)
    np.testing.assert_array_equal(from_scene.faces, duck.faces)


def test_open3d_meshes_and_point_clouds_are_read(bunny_sample):
    require_package("open3d")
    import open3d as o3d

    mesh = load_mesh(sample_path("teapot.stl"))
    triangles = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(np.array(mesh.vertices)),
        o3d.utility.Vector3iVector(np.array(mesh.faces, np.int32)))
    assert isinstance(load(triangles), Mesh)
    points = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(bunny_sample.points))
    assert load(points).normals is None
    points.normals = o3d.utility.Vector3dVector(bunny_sample.normals)
    cloud = load(points)
    assert isinstance(cloud, PointCloud)
    np.testing.assert_allclose(cloud.normals, bunny_sample.normals, atol=1e-12)


def test_a_point_cloud_is_checked_once_like_a_mesh():
    with pytest.raises(InputError, match="scan: point cloud has no points"):
        PointCloud(np.zeros((0, 3)), name="scan")
    with pytest.raises(InputError, match=r"scan: its 1 point\(s\) lie on one line"):
        PointCloud(np.ones((1, 3)), name="scan")
    with pytest.raises(InputError, match="scan: 1 points have NaN or infinite coordinates"):
        PointCloud([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], name="scan")
    with pytest.raises(InputError, match="overflow the float32"):
        PointCloud(np.eye(3) * 1e39, name="scan")
    with pytest.raises(InputError, match="a normal is NaN, infinite or of zero length"):
        PointCloud(np.eye(3), np.zeros((3, 3)), name="scan")
    for scale in (1e-30, 1e30):  # any scale a mesh may have
        cloud = PointCloud(np.eye(3) * scale, np.eye(3) * scale)
        np.testing.assert_allclose(cloud.normals, np.eye(3))
    cloud = PointCloud(np.eye(3))
    with pytest.raises(ValueError):
        cloud.points[0, 0] = 2.0


def test_files_of_one_stem_are_named_by_their_paths_under_the_folder_they_share(tmp_path):
    for folder, sample, suffix in (("a", "teapot", ".stl"), ("b", "mug", ".obj")):
        (tmp_path / folder).mkdir()
        shutil.copy(sample_path(sample), tmp_path / folder / f"teapot{suffix}")
    shutil.copy(sample_path("ballA"), tmp_path / "a" / "ballA.off")
    with open_inputs([tmp_path / "a" / "teapot.stl", tmp_path / "b" / "teapot.obj"]) as sources:
        assert [source.name for source in sources] == ["a__teapot", "b__teapot"]
        assert [source.model().name for source in sources] == ["a__teapot", "b__teapot"]
        assert sources[1].model().n_faces == load_mesh(sample_path("mug")).n_faces
    with open_inputs([tmp_path / "a" / "teapot.stl", tmp_path / "a" / "ballA.off"]) as sources:
        assert [source.name for source in sources] == ["teapot", "ballA"]
    with open_inputs([tmp_path / "b" / "teapot.obj", sample_path("mug.obj")]) as sources:
        assert [source.name for source in sources] == ["teapot", "mug"]
