"""Point cloud files: each format read with its normals and colours; bad input is one line."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from fixtures.environment import require_package
from vptoolkit.cli import main
from vptoolkit.errors import InputError, MeshLoadError
from vptoolkit.inputs import open_inputs
from vptoolkit.io import load, load_mesh, load_with_appearance
from vptoolkit.point_cloud import PointCloud, voxel_subset
from vptoolkit.points import sample_surface
from vptoolkit.samples import sample_path


@pytest.fixture(scope="module")
def sample():
    """1000 points of the bunny with their normals and a colour from their height."""
    surface = sample_surface(load_mesh(sample_path("bunny.ply")), 1000, seed=0)
    height = surface.points[:, 1]
    shade = np.rint(255 * (height - height.min()) / np.ptp(height)).astype(np.uint8)
    colors = np.stack([shade, 255 - shade, np.full_like(shade, 7)], axis=1)
    return surface.points, surface.normals, colors


def write_text(path, rows, fmt="%.9g"):
    np.savetxt(path, rows, fmt=fmt)
    return path


def test_xyz_xyzn_and_xyzrgb(tmp_path, sample):
    points, normals, colors = sample
    cloud = load(write_text(tmp_path / "a.xyz", points))
    assert isinstance(cloud, PointCloud) and cloud.normals is None and cloud.name == "a"
    np.testing.assert_allclose(cloud.points, points, rtol=1e-8)
    cloud = load(write_text(tmp_path / "b.xyzn", np.concatenate([points, normals], axis=1)))
    np.testing.assert_allclose(cloud.normals, normals, atol=1e-8)
    path = write_text(tmp_path / "c.xyzrgb", np.concatenate([points, colors / 255], axis=1))
    cloud, look = load_with_appearance(path)
    np.testing.assert_array_equal(look.vertex_colors[:, :3], colors)
    assert (look.vertex_colors[:, 3] == 255).all()


def test_pts_with_count_intensity_and_colours(tmp_path, sample):
    points, _, colors = sample
    body = "".join(f"{x:.9g} {y:.9g} {z:.9g} 12 {r} {g} {b}\n"
                   for (x, y, z), (r, g, b) in zip(points, colors))
    (tmp_path / "scan.pts").write_text(f"{len(points)}\n{body}")
    cloud, look = load_with_appearance(tmp_path / "scan.pts")
    np.testing.assert_allclose(cloud.points, points, rtol=1e-8)
    np.testing.assert_array_equal(look.vertex_colors[:, :3], colors)
    (tmp_path / "short.pts").write_text(f"{len(points) + 5}\n{body}")
    with pytest.raises(MeshLoadError, match=r"^short\.pts: header declares 1005 points, "
                                            r"file has 1000$"):
        load(tmp_path / "short.pts")


def test_pcd_ascii_and_binary_through_open3d(tmp_path, sample):
    require_package("open3d")
    import open3d as o3d

    points, normals, colors = sample
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    cloud.normals = o3d.utility.Vector3dVector(normals)
    cloud.colors = o3d.utility.Vector3dVector(colors / 255.0)
    for ascii in (True, False):
        path = tmp_path / f"scan_{ascii}.pcd"
        assert o3d.io.write_point_cloud(str(path), cloud, write_ascii=ascii)
        read, look = load_with_appearance(path)
        np.testing.assert_allclose(read.points, points, atol=1e-6)
        np.testing.assert_allclose(read.normals, normals, atol=1e-5)
        np.testing.assert_array_equal(look.vertex_colors[:, :3], colors)


def test_npy_and_npz(tmp_path, sample):
    points, normals, colors = sample
    np.save(tmp_path / "six.npy", np.concatenate([points, normals], axis=1))
    np.testing.assert_allclose(load(tmp_path / "six.npy").normals, normals)
    np.savez(tmp_path / "named.npz", points=points, normals=normals, colors=colors)
    cloud, look = load_with_appearance(tmp_path / "named.npz")
    np.testing.assert_array_equal(cloud.points, points)
    np.testing.assert_array_equal(look.vertex_colors[:, :3], colors)
    np.savez_compressed(tmp_path / "one.npz", scan=points)
    np.testing.assert_array_equal(load(tmp_path / "one.npz").points, points)
    np.savez(tmp_path / "odd.npz", points=points, labels=np.zeros(len(points)))
    with pytest.raises(MeshLoadError, match=r"^odd\.npz: unknown arrays \['labels'\]"):
        load(tmp_path / "odd.npz")


def test_las_and_a_las_without_points(tmp_path, sample):
    require_package("laspy")
    import laspy

    points, _, colors = sample
    header = laspy.LasHeader(point_format=2, version="1.2")
    header.scales = np.full(3, 1e-7)
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    las.red, las.green, las.blue = (colors.astype(np.uint16) * 257).T
    las.write(str(tmp_path / "scan.las"))
    cloud, look = load_with_appearance(tmp_path / "scan.las")
    np.testing.assert_allclose(cloud.points, points, atol=1e-6)
    np.testing.assert_array_equal(look.vertex_colors[:, :3], colors)
    laspy.LasData(laspy.LasHeader(point_format=2, version="1.2")).write(str(tmp_path / "no.las"))
    with pytest.raises(MeshLoadError, match=r"^no\.las: holds no points"):
        load(tmp_path / "no.las")


def test_python_objects_are_point_clouds_too(sample):
    points, normals, _ = sample
    assert load(np.concatenate([points, normals], axis=1)).normals is not None


def _ply(tmp_path, name, rows, extra=""):
    body = "".join(" ".join(map(str, row)) + "\n" for row in rows)
    (tmp_path / name).write_text(
        f"ply\nformat ascii 1.0\nelement vertex {len(rows)}\nproperty double x\n"
        f"property double y\nproperty double z\n{extra}end_header\n{body}")
    return tmp_path / name


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ([], r"no geometry"),
        ([(1, 2, 3)], r"its 1 point\(s\) lie on one line"),
        ([(1, 2, 3)] * 50, r"its 50 point\(s\) lie on one line"),
        ([(0, 0, 0), (1, 0, 0), (0, float("nan"), 0)], r"1 points have NaN or infinite"),
        ([(0, 0, 0), (1, 0, 0), (0, float("inf"), 0)], r"1 points have NaN or infinite"),
        ([(0, 0, 0), (1e39, 0, 0), (0, 1, 0)], r"overflow the float32"),
        ([(0, 0, 0), (1e-40, 0, 0), (0, 1e-40, 0)], r"underflow the float32"),
    ],
    ids=["empty", "one-point", "all-equal", "nan", "inf", "huge", "tiny"],
)
def test_bad_clouds_are_refused_in_one_line(tmp_path, rows, message):
    path = _ply(tmp_path, "scan.ply", rows)
    with pytest.raises(MeshLoadError, match=rf"^scan\.ply: .*{message}") as raised:
        load(path)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize("scale", [1e-30, 1e30])
def test_clouds_of_any_scale_a_mesh_may_have_are_read(tmp_path, sample, scale):
    points, _, _ = sample
    np.save(tmp_path / "scaled.npy", points * scale)
    cloud = load(tmp_path / "scaled.npy")
    np.testing.assert_allclose(cloud.points, points * scale)


def test_a_header_promising_a_billion_points_is_refused_before_allocating(tmp_path):
    (tmp_path / "big.pcd").write_text(
        "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1000000000\n"
        "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1000000000\nDATA binary\n" + "x" * 120)
    with pytest.raises(MeshLoadError, match=r"^big\.pcd: PCD header declares 1,000,000,000 "
                                            r"points, more than its \d+ bytes can hold$"):
        load(tmp_path / "big.pcd")
    (tmp_path / "big.ply").write_bytes(
        b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\n"
        b"property float y\nproperty float z\nend_header\n" + bytes(120))
    with pytest.raises(MeshLoadError, match=r"^big\.ply: PLY file ends before the "
                                            r"1000000000 vertices its header declares$"):
        load(tmp_path / "big.ply")
    header = {"descr": "<f8", "fortran_order": False, "shape": (10**9, 3)}
    with open(tmp_path / "big.npy", "wb") as stream:
        np.lib.format.write_array_header_1_0(stream, header)
        stream.write(bytes(120))
    with pytest.raises(MeshLoadError, match=r"^big\.npy: "):
        load(tmp_path / "big.npy")


def test_colours_out_of_range_are_refused(tmp_path, sample):
    points, _, colors = sample
    bad = np.concatenate([points, colors / 100.0], axis=1)  # up to 2.55 in a 0..1 format
    with pytest.raises(MeshLoadError, match=r"^bad\.xyzrgb: point colours outside 0\.\.1"):
        load(write_text(tmp_path / "bad.xyzrgb", bad))
    rows = [(0, 0, 0, 300, 0, 0), (1, 0, 0, 0, 0, 0), (0, 1, 0, 0, 0, 0)]
    (tmp_path / "bad.pts").write_text("".join(" ".join(map(str, row)) + "\n" for row in rows))
    with pytest.raises(MeshLoadError, match=r"^bad\.pts: point colours outside 0\.\.255"):
        load(tmp_path / "bad.pts")


def test_a_bad_line_names_its_number(tmp_path):
    (tmp_path / "scan.xyz").write_text("0 0 0\n1 0 0\nfoo bar baz\n0 1 0\n")
    with pytest.raises(MeshLoadError, match=r"^scan\.xyz: line 3: cannot read point values"):
        load(tmp_path / "scan.xyz")


def test_a_cloud_over_max_points_is_thinned_with_a_warning(tmp_path, sample, caplog):
    points, normals, colors = sample
    np.savez(tmp_path / "dense.npz", points=points, normals=normals, colors=colors)
    with caplog.at_level(logging.WARNING):
        cloud = load(tmp_path / "dense.npz", max_points=200)
    assert 10 < cloud.n_points <= 200
    assert "dense.npz: 1,000 points, more than max_points=200; kept" in caplog.text
    kept = voxel_subset(points, 200)
    np.testing.assert_array_equal(cloud.points, points[kept])
    np.testing.assert_allclose(cloud.normals, normals[kept])
    assert len(voxel_subset(points, 5000)) == len(points)
    with open_inputs(tmp_path / "dense.npz", max_points=200) as sources:
        np.testing.assert_array_equal(sources[0].points(seed=0), points[kept])
    with pytest.raises(InputError, match="max_points"):
        load(tmp_path / "dense.npz", max_points=0)


def test_commands_read_clouds_where_points_suffice_and_refuse_them_elsewhere(tmp_path, sample,
                                                                            runner):
    points, normals, _ = sample
    path = write_text(tmp_path / "bunny.xyzn", np.concatenate([points, normals], axis=1))
    result = runner.invoke(main, ["predict", "--model", "unoccluded", str(path)])
    assert result.exit_code == 0, result.output
    result = runner.invoke(main, ["sample", str(path), "-o", str(tmp_path / "out.npy")])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and "bunny.xyzn: a point cloud (1000 points" in (
        result.stderr)
    assert not (tmp_path / "out.npy").exists()


def _voxel_rule(points, max_points):
    """The rule of voxel_subset written out on (n, 3) cells: the reference its int64 keys
    must match index for index."""
    if len(points) <= max_points:
        return np.arange(len(points))
    low = points.min(axis=0)
    extent = float(np.ptp(points, axis=0).max())
    scaled = (points - low) / extent if extent > 0 else np.zeros_like(points)

    def firsts(side):
        return np.unique(np.floor(scaled / side).astype(np.int64), axis=0, return_index=True)[1]

    sides = [float(max_points ** (-1.0 / 3.0) * 1.25 ** np.float64(k)) for k in range(-80, 80)]
    fitting = [side for side in sides if side >= 1e-6 and len(firsts(side)) <= max_points]
    return np.sort(firsts(min(fitting)))


@pytest.mark.parametrize("max_points", [1, 7, 200, 999])
def test_voxel_subset_keeps_the_first_point_of_each_cell_of_the_rule(sample, max_points):
    points = sample[0]
    flat = points * np.array([1.0, 0.0, 1.0])  # one axis of zero extent
    repeated = np.repeat(points[:50], 20, axis=0)  # many points per cell, in file order
    for cloud in (points, flat, repeated, np.zeros((30, 3))):
        np.testing.assert_array_equal(voxel_subset(cloud, max_points),
                                      _voxel_rule(cloud, max_points))
