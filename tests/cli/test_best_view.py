"""vptool best-view over a collection: a folder into OUT/<digest>/, failures and exit status 1."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from fixtures.paths import MALFORMED
from vptoolkit.cli import main
from vptoolkit.predictions import Predictions
from vptoolkit.samples import sample_path

SMALL = ["--views", "12", "--resolution", "32"]


def _collection(root: Path) -> Path:
    (root / "a").mkdir(parents=True)
    (root / "b").mkdir()
    shutil.copy(sample_path("teapot.stl"), root / "a" / "teapot.stl")
    shutil.copy(sample_path("mug.obj"), root / "b" / "teapot.stl.obj")
    shutil.copy(MALFORMED / "empty.stl", root / "b" / "empty.stl")
    return root


def test_a_folder_is_searched_into_a_table_and_exits_1_on_a_broken_file(runner, tmp_path):
    source = _collection(tmp_path / "coll")
    out = tmp_path / "views"
    result = runner.invoke(main, ["best-view", str(source), "-o", str(out), *SMALL,
                                  "--workers", "2"])
    assert result.exit_code == 1, result.output
    assert result.stdout.startswith("searched 3 files (0 from an earlier run), 1 failed: ")
    assert "  failed b/empty.stl: empty.stl: " in result.stderr
    (folder,) = out.iterdir()
    predictions = Predictions.load_npz(folder / "predictions.npz")
    assert predictions.names == ("a/teapot.stl", "b/teapot.stl.obj")
    assert np.allclose(np.linalg.norm(predictions.directions, axis=-1), 1.0)
    table = (folder / "table.parquet").read_bytes()
    again = runner.invoke(main, ["best-view", str(source), "-o", str(out), *SMALL])
    assert again.exit_code == 1
    assert again.stdout.startswith("searched 3 files (3 from an earlier run), 1 failed")
    assert (folder / "table.parquet").read_bytes() == table


def test_a_list_file_and_a_dry_run(runner, tmp_path):
    source = _collection(tmp_path / "coll")
    listing = source / "models.txt"
    listing.write_text("a/teapot.stl\nb/teapot.stl.obj\n")
    result = runner.invoke(main, ["best-view", f"@{listing}", "-o", str(tmp_path / "out"),
                                  *SMALL, "--dry-run"])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0].startswith("2 files (") and lines[1].startswith("estimate from 2 files: ")
    assert not (tmp_path / "out").exists()
    result = runner.invoke(main, ["best-view", f"@{listing}", "-o", str(tmp_path / "out"),
                                  *SMALL])
    assert result.exit_code == 0, result.output


def test_workers_without_a_collection_and_a_collection_without_output_are_refused(
        runner, tmp_path):
    source = _collection(tmp_path / "coll")
    result = runner.invoke(main, ["best-view", str(source / "a" / "teapot.stl"), "--workers",
                                  "2"])
    assert result.exit_code == 2
    assert "--workers, --scheduler and --dry-run take a collection" in result.stderr
    result = runner.invoke(main, ["best-view", str(source)])
    assert result.exit_code == 2 and "--output: a collection needs -o OUT" in result.stderr


def _torus_points(n_points: int = 20000):
    from vptoolkit.io import load_mesh
    from vptoolkit.points import sample_surface

    return sample_surface(load_mesh(sample_path("torus.STL")), n_points, seed=0)


def test_a_cloud_in_any_format_is_searched_and_the_same_points_give_the_same_answer(
        runner, tmp_path):
    # The points written by numpy and by Open3D (binary PLY, PCD, XYZ) with and
    # without normals: float32 files hold the points np.save keeps as float32.
    from fixtures.environment import require_package

    require_package("open3d")
    import open3d as o3d

    sample = _torus_points()
    points, normals = sample.points.astype(np.float32), sample.normals.astype(np.float32)
    np.save(tmp_path / "a.npy", np.concatenate([points, normals], axis=1))
    np.save(tmp_path / "plain.npy", points)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float64)))
    o3d.io.write_point_cloud(str(tmp_path / "plain.ply"), cloud)
    o3d.io.write_point_cloud(str(tmp_path / "plain.xyz"), cloud)
    cloud.normals = o3d.utility.Vector3dVector(normals.astype(np.float64))
    o3d.io.write_point_cloud(str(tmp_path / "b.ply"), cloud)
    o3d.io.write_point_cloud(str(tmp_path / "b.pcd"), cloud)
    answers = {}
    for name in ("a.npy", "b.ply", "b.pcd", "plain.npy", "plain.ply", "plain.xyz"):
        result = runner.invoke(main, ["best-view", str(tmp_path / name), *SMALL, "--json"])
        assert result.exit_code == 0, result.output
        (entry,) = json.loads(result.stdout)["results"]
        answers[name] = [best["direction"] for best in entry["best"].values()]
    assert answers["a.npy"] == answers["b.ply"] == answers["b.pcd"]
    assert answers["plain.npy"] == answers["plain.ply"]
    # XYZ text keeps fewer digits: the same points up to rounding, about the same answer
    assert np.allclose(answers["plain.xyz"], answers["plain.ply"], atol=0.2)


def test_a_measure_not_defined_on_points_is_refused_for_a_cloud_in_one_line(runner, tmp_path):
    np.save(tmp_path / "scan.npy", _torus_points(2000).points)
    result = runner.invoke(main, ["best-view", str(tmp_path / "scan.npy"), *SMALL,
                                  "--measures", "VE,SL"])
    assert result.exit_code == 2
    assert result.stderr.splitlines()[-1] == (
        "vptool: error: scan: SL is not defined on a point cloud (reading silhouettes); "
        "on points: NVT, PA, HM, VR, VE, VKL, VMI, I2, I3, INS, SAL, EVMI")
