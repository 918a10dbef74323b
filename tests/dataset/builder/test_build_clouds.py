"""Building a dataset from point clouds, alone and beside meshes: labels of the points, the
stored sample taken from the cloud, zero faces, and a release of such a store."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from vptoolkit.data import open_dataset
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.builder.run import BuildResult, build_dataset
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.errors import InputError
from vptoolkit.io import load
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings

TINY = BuildOptions(MeasureSettings(views=20, resolution=32), n_points=500, clean=False)


@pytest.fixture(scope="module")
def scans(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``scans/``: the bunny's surface as 2000 points with normals (PLY), the same points
    without normals (NPY), 300 of them (PCD); ``meshes/mug.obj`` beside them."""
    require_package("open3d")
    require_package("zarr")
    import open3d as o3d

    root = tmp_path_factory.mktemp("clouds") / "src"
    (root / "scans").mkdir(parents=True)
    (root / "meshes").mkdir()
    bunny = o3d.io.read_triangle_mesh(str(sample_path("bunny")))
    bunny.compute_vertex_normals()
    cloud = bunny.sample_points_uniformly(2000)
    o3d.io.write_point_cloud(str(root / "scans" / "bunny.ply"), cloud)
    np.save(root / "scans" / "bare.npy", np.asarray(cloud.points))
    o3d.io.write_point_cloud(str(root / "scans" / "few.pcd"), cloud.select_by_index(range(300)))
    shutil.copyfile(sample_path("mug"), root / "meshes" / "mug.obj")
    return root


@pytest.fixture(scope="module")
def built(scans: Path, tmp_path_factory: pytest.TempPathFactory) -> BuildResult:
    return build_dataset(scans, tmp_path_factory.mktemp("built") / "out", TINY)


def test_clouds_and_a_mesh_build_one_store(scans, built):
    assert (built.n_models, built.n_failures) == (4, 0)
    with open_dataset(built.path) as dataset:
        assert dataset.names == ["meshes__mug", "scans__bare", "scans__bunny", "scans__few"]
        assert dataset.categories == ["meshes", "scans", "scans", "scans"]
        assert [int(label) for label in dataset.labels] == [0, 1, 1, 1]
        for name in dataset.names:
            item = dataset[name]
            assert item["points"].shape == (500, 3) and item["normals"].shape == (500, 3)
            assert np.allclose(np.linalg.norm(item["normals"], axis=1), 1.0, atol=1e-3)
            vertices, faces = dataset.mesh(name)
            assert (len(vertices) == len(faces) == 0) == name.startswith("scans__")
    with open_store(built.path) as store:
        records = {record["name"]: record for record in store.models()}
    assert records["scans__bunny"]["n_faces"] == records["scans__bunny"]["n_vertices"] == 0
    assert records["scans__bunny"]["cleaning"] is None
    assert records["scans__few"]["source"] == "scans/few.pcd"


def test_face_features_of_a_cloud_are_refused_in_one_line(built):
    with open_dataset(built.path) as dataset, \
            pytest.raises(InputError, match=r"^scans__bunny: stored without faces .*"
                                            r"--point-features none\)$"):
        dataset.point_features("scans__bunny", ["face_area"])


def test_a_clouds_labels_are_those_of_its_points(scans, built):
    cloud = load(scans / "scans" / "bunny.ply")
    expected = compute_view_quality(cloud, TINY.measure, measures=TINY.measures)
    with open_dataset(built.path) as dataset:
        item = dataset["scans__bunny"]
        assert np.allclose(item["quality_raw"], expected.raw.astype(np.float32), equal_nan=True)
        assert np.array_equal(item["best_index"], expected.best_index)


def test_the_stored_points_are_the_clouds_own_with_their_normals(scans, built):
    cloud = load(scans / "scans" / "bunny.ply")
    few = load(scans / "scans" / "few.pcd")
    with open_dataset(built.path) as dataset:
        bunny, bare, repeated = (dataset[name] for name in
                                 ("scans__bunny", "scans__bare", "scans__few"))
    rows = {tuple(point): row for row, point in enumerate(cloud.points.astype(np.float32))}
    chosen = [rows[tuple(point)] for point in bunny["points"]]
    assert len(set(chosen)) == 500 and chosen == sorted(chosen)  # thinned, in file order
    assert np.allclose(bunny["normals"], cloud.normals[chosen], atol=1e-6)
    # without normals in the file, each is a plane fit turned away from the centre
    centred = bare["points"] - cloud.points.mean(axis=0)
    assert (np.einsum("ni,ni->n", bare["normals"], centred) >= 0).all()
    agree = np.abs(np.einsum("ni,ni->n", bare["normals"], cloud.normals[
        [rows[tuple(point)] for point in bare["points"]]]))
    assert np.median(agree) > 0.9
    # 300 points for 500 places: every point once, 200 of them again
    assert len(np.unique(repeated["points"], axis=0)) == few.n_points


def test_a_measure_points_cannot_give_fails_each_cloud_in_one_line(scans, tmp_path):
    result = build_dataset(scans, tmp_path / "out", replace(TINY, measures="VE,SL"))
    assert result.n_models == 1 and result.n_failures == 3
    for failure in result.failures:
        assert "SL is not defined on a point cloud (reading silhouettes)" in failure["reason"]
        assert "\n" not in failure["reason"] and failure["source"].startswith("scans/")


def test_a_cloud_build_resumes_to_the_same_bytes(scans, built):
    with open_store(built.path) as store:
        before = {name: store.stored_sha256(name) for name in store.array_names()}
    again = build_dataset(scans, built.path.parent, TINY)
    assert again.n_resumed == 4
    with open_store(again.path) as store:
        assert {name: store.stored_sha256(name) for name in store.array_names()} == before


def test_a_store_of_clouds_packs_and_verifies(built, tmp_path):
    require_package("pyarrow")
    from vptoolkit.dataset.release.manifest import verify
    from vptoolkit.dataset.release.pack import pack_release

    release = pack_release(built.path.parent, tmp_path / "release")
    assert verify(release.path).ok
    with open_dataset(release.path) as dataset:
        assert dataset.names == ["meshes__mug", "scans__bare", "scans__bunny", "scans__few"]
        assert len(dataset.mesh("scans__bunny")[1]) == 0


def test_scan_sampling_stores_a_virtual_scan_with_the_meshs_labels(scans, built, tmp_path):
    from vptoolkit.cloud_sample import sample_cloud
    from vptoolkit.dataset.builder.sources import model_seed
    from vptoolkit.mesh import Mesh
    from vptoolkit.point_cloud import PointCloud
    from vptoolkit.scan import virtual_scan

    source = tmp_path / "src"
    shutil.copytree(scans / "meshes", source / "meshes")
    scanned = build_dataset(source, tmp_path / "scanned", replace(TINY, sampling="scan"))
    with open_dataset(scanned.path) as dataset, open_dataset(built.path) as uniform:
        assert dataset.names == ["meshes__mug"]
        item = dataset["meshes__mug"]
        np.testing.assert_array_equal(item["quality"], uniform["meshes__mug"]["quality"])
        assert dataset.attrs["sampling"] == "scan" and "sampling" not in uniform.attrs
        vertices, faces = dataset.mesh("meshes__mug")
        mesh = Mesh(vertices.astype(np.float64), faces.astype(np.int64), name="mug")
    seed = model_seed(TINY.split_seed, "meshes/meshes__mug")
    points, normals = virtual_scan(mesh, seed=seed)
    expected = sample_cloud(PointCloud(points, normals), 500, seed=seed)
    np.testing.assert_allclose(item["points"], expected.points, atol=1e-5)
    np.testing.assert_allclose(item["normals"], expected.normals, atol=1e-5)
    with pytest.raises(InputError, match="^sampling: expected one of uniform, scan"):
        replace(TINY, sampling="poisson")
