"""vptool measures, views, clean and sample."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from fixtures.commands import SMALL_DRAW
from fixtures.paths import MALFORMED
from vptoolkit.cli import main
from vptoolkit.samples import sample_path


def test_measures_prints_the_best_view_per_measure(runner):
    result = runner.invoke(main, ["measures", str(sample_path("suzanne.ply")),
                                  "--views", "200", "--resolution", "128"])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0].startswith("suzanne: 968 faces, 200 views at 128 px (raster")
    assert [line.split()[0] for line in lines[2:6]] == ["VE", "VR", "VKL", "VMI"]


def test_measures_json_and_npz_agree(runner, tmp_path):
    out = tmp_path / "teapot.npz"
    result = runner.invoke(main, ["measures", str(sample_path("teapot.stl")), "--views", "100",
                                  "--resolution", "96", "--json", "-o", str(out)])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert list(summary["best"]) == ["VE", "VR", "VKL", "VMI"]
    assert summary["camera"]["fov_deg"] == 45.0
    with np.load(out, allow_pickle=False) as stored:
        best = stored["best_index"]
        assert [summary["best"][m]["view_index"] for m in ("VE", "VR", "VKL", "VMI")] == list(best)


def _refuse(constant: str) -> None:
    raise ValueError(f"not JSON: {constant}")


def test_measures_json_writes_null_for_a_measure_undefined_in_every_view(runner):
    # INS compares a view with its neighbours: with one view it is NaN everywhere
    result = runner.invoke(main, ["measures", str(sample_path("torus.STL")), "--measures",
                                  "INS,VE", "--json", "--views", "1", "--resolution", "16"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout, parse_constant=_refuse)  # strict: no bare NaN
    assert summary["best"]["INS"]["raw"] is None
    assert summary["best"]["VE"]["raw"] > 0


def test_raycast_backend_from_the_command_line(runner):
    result = runner.invoke(main, ["measures", str(sample_path("angle_block.STL")), "--views", "8",
                                  "--resolution", "64", "--backend", "raycast", "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["backend"] == "raycast"


@pytest.mark.parametrize("name", ["empty.obj", "empty.stl", "ply_empty_header.ply"])
def test_malformed_mesh_is_one_line_and_exit_2(runner, name):
    result = runner.invoke(main, ["measures", str(MALFORMED / name), "--views", "4"])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.output
    assert result.stderr.startswith(f"vptool: error: {name}: ")


def test_bad_output_suffix_is_bad_input(runner, tmp_path):
    result = runner.invoke(main, ["measures", str(sample_path("teapot.stl")), "-o",
                                  str(tmp_path / "out.txt")])
    assert result.exit_code == 2
    assert "out.txt: output must end in .npz" in result.stderr


def test_missing_file_and_bad_option_exit_2(runner, tmp_path):
    assert runner.invoke(main, ["measures", str(tmp_path / "nope.off")]).exit_code == 2
    assert runner.invoke(main, ["measures", str(sample_path("teapot.stl")),
                                "--views", "0"]).exit_code == 2


def test_clean_writes_mesh_and_report(runner, tmp_path):
    target, report = tmp_path / "bunny_clean.ply", tmp_path / "report.json"
    source = str(sample_path("bunny.ply"))
    result = runner.invoke(main, ["clean", source, str(target), "--max-faces", "3000",
                                  "--report", str(report), "--json"])
    assert result.exit_code == 0, result.output
    from vptoolkit.io import load_mesh

    n_faces = load_mesh(target).n_faces
    assert n_faces <= 3000
    written = json.loads(report.read_text())
    assert [step["name"] for step in written["steps"]] == ["repair", "remove_hidden", "simplify"]
    record = json.loads(result.stdout, parse_constant=_refuse)  # stdout: the JSON alone
    assert list(record)[:3] == ["file", "name", "output"]
    assert (record["file"], record["name"], record["output"]) == (source, "bunny", str(target))
    assert record["faces_before"] == 16301 and record["faces_after"] == n_faces
    assert {key: value for key, value in record.items()
            if key not in ("file", "output")} == written  # the --report, placed


def test_sample_writes_points_with_normals(runner, tmp_path):
    out = tmp_path / "points.npy"
    args = ["sample", str(sample_path("teapot.stl")), "-o", str(out), "--points", "500"]
    assert runner.invoke(main, args).exit_code == 0
    first = np.load(out, allow_pickle=False)
    assert first.shape == (500, 6) and first.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(first[:, 3:], axis=1), 1.0, atol=1e-5)
    assert runner.invoke(main, args).exit_code == 0
    np.testing.assert_array_equal(np.load(out, allow_pickle=False), first)
    bad = runner.invoke(main, ["sample", str(MALFORMED / "empty.obj"), "-o", str(out)])
    assert bad.exit_code == 2 and bad.stderr.startswith("vptool: error: empty.obj: ")


def test_sample_json_is_the_record_of_the_points_written(runner, tmp_path):
    out = tmp_path / "points.npy"
    teapot = str(sample_path("teapot.stl"))
    result = runner.invoke(main, ["sample", teapot, "-o", str(out), "--points", "300",
                                  "--seed", "4", "--json"])
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout, parse_constant=_refuse)
    seconds = record.pop("seconds")
    assert record == {"file": teapot, "name": "teapot", "output": str(out), "points": 300,
                      "seed": 4}
    assert seconds >= 0 and np.load(out, allow_pickle=False).shape == (300, 6)
    bad = runner.invoke(main, ["sample", str(MALFORMED / "empty.obj"), "-o", str(out), "--json"])
    assert bad.exit_code == 2 and bad.stdout == ""
    assert one_error_line(bad).startswith("vptool: error: empty.obj: ")


def one_error_line(result) -> str:
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert lines[0].startswith("vptool: error: ")
    return lines[0]


def test_views_prints_one_row_per_pick_with_rising_coverage(runner):
    result = runner.invoke(main, ["views", str(sample_path("suzanne.ply")), *SMALL_DRAW])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0].startswith("suzanne: 968 faces, 120 views at 96 px, coverage objective")
    rows = [line.split() for line in lines[2:6]]
    assert [row[0] for row in rows] == ["1", "2", "3", "4"]
    coverage = [float(row[-2]) for row in rows]
    assert coverage == sorted(coverage) and coverage[-1] > coverage[0]
    assert lines[6].startswith("reachable: ")


def test_views_json_and_npz_agree(runner, tmp_path):
    out = tmp_path / "teapot_views.npz"
    result = runner.invoke(main, ["views", str(sample_path("teapot.stl")), *SMALL_DRAW, "--k", "3",
                                  "--objective", "information", "--json", "-o", str(out)])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["objective"] == "information" and len(summary["picks"]) == 3
    with np.load(out, allow_pickle=False) as stored:
        assert stored["indices"].tolist() == [p["view_index"] for p in summary["picks"]]


def test_views_until_a_coverage_target(runner):
    result = runner.invoke(main, ["views", str(sample_path("mug.obj")), *SMALL_DRAW,
                                  "--coverage", "0.9", "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    coverage = [pick["coverage"] for pick in summary["picks"]]
    assert coverage[-1] >= 0.9 * summary["reachable"] - 1e-6
    assert len(coverage) == 1 or coverage[-2] < 0.9 * summary["reachable"]


def test_views_take_any_registered_measure_in_any_case(runner):
    mug = str(sample_path("mug.obj"))
    result = runner.invoke(main, ["views", mug, "--views", "40", "--resolution", "48", "--k",
                                  "2", "--objective", "quality", "--measure", "sl", "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["measure"] == "SL" and len(summary["picks"]) == 2
    refused = runner.invoke(main, ["views", mug, "--objective", "quality", "--measure", "XX"])
    assert refused.exit_code == 2
    assert refused.stderr.startswith("vptool: error: --measure: unknown measure 'XX'; known: ")
    assert refused.stderr.count("\n") == 1


@pytest.mark.parametrize("name", ["empty.obj", "empty.stl", "ply_empty_header.ply", "README.md"])
def test_views_of_a_malformed_file_is_one_line_and_exit_2(runner, name):
    result = runner.invoke(main, ["views", str(MALFORMED / name), "--views", "8"])
    assert result.exit_code == 2
    assert one_error_line(result).startswith(f"vptool: error: {name}: ")


@pytest.mark.parametrize("arguments, message", [
    (["-o", "set.txt"], "set.txt: output must end in .npz"),
    (["--coverage", "1.5"], "--coverage"),
    (["--k", "0"], "--k"),
    (["--objective", "beauty"], "--objective"),
], ids=["suffix", "target", "k", "objective"])
def test_views_rejects_bad_options_with_exit_2(runner, tmp_path, arguments, message):
    result = runner.invoke(main, ["views", str(sample_path("mug.obj")), *arguments],
                           catch_exceptions=False)
    assert result.exit_code == 2
    assert message in result.stderr and "Traceback" not in result.output


@pytest.mark.parametrize("arguments, expected", [
    (["--coverage", "nan"], "--coverage: must lie in (0, 1], got nan"),
    (["-o", "missing/v.npz"], "--output: missing/v.npz: output folder missing does not exist"),
])
def test_views_refuses_a_bad_target_or_output_folder_before_drawing(runner, monkeypatch,
                                                                    tmp_path, arguments,
                                                                    expected):
    import vptoolkit.view_sets.search

    def never(*args, **kwargs):
        raise AssertionError("the views were drawn")

    monkeypatch.setattr(vptoolkit.view_sets.search, "measure_view_set", never)
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(main, ["views", str(sample_path("mug.obj")), *SMALL_DRAW, *arguments])
    assert result.exit_code == 2, result.output
    assert one_error_line(result) == f"vptool: error: {expected}"


def test_views_with_an_unreachable_min_pixels_is_a_failure(runner, tmp_path):
    out = tmp_path / "v.npz"
    result = runner.invoke(main, ["views", str(sample_path("mug.obj")), "--views", "12",
                                  "--resolution", "16", "--min-pixels", "100000",
                                  "-o", str(out)])
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output
    line = result.stderr.strip().splitlines()[-1]  # after the progress bar
    assert line.startswith("vptool: error: ") and "--min-pixels" in line
    assert "no face has 100000 pixels in any of the 12 views" in line
    assert not out.exists()


# --- measures chosen by name --------------------------------------------------------------


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


def test_cli_measures_by_name_in_table_json_and_npz(runner, tmp_path):
    mesh = str(sample_path("suzanne.ply"))
    table = runner.invoke(main, ["measures", mesh, "--views", "60", "--resolution", "96",
                                 "--measures", "NVT,I2,INS"])
    assert table.exit_code == 0, table.output
    rows = [line.split() for line in table.stdout.splitlines()[2:5]]
    assert [(row[0], row[-1]) for row in rows] == [("NVT", "max"), ("I2", "min"), ("INS", "min")]
    out = tmp_path / "suzanne.npz"
    result = runner.invoke(main, ["measures", mesh, "--views", "60", "--resolution", "96",
                                  "--measures", "PA,VE", "--json", "-o", str(out)])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert list(summary["best"]) == ["PA", "VE"]
    with np.load(out, allow_pickle=False) as stored:
        assert tuple(stored["measures"]) == ("PA", "VE")
        assert [summary["best"][m]["view_index"] for m in ("PA", "VE")] == list(
            stored["best_index"])


@pytest.mark.parametrize("spec, message", [
    ("VE,XYZ", "--measures: unknown measure 'XYZ'; known: NVT, PA"),
    ("VE,VE", "--measures: VE named twice"),
    (" , ", "--measures: no measure named"),
])
def test_cli_bad_measure_names_are_one_line_and_exit_2(runner, spec, message):
    result = runner.invoke(main, ["measures", str(sample_path("teapot.stl")),
                                  "--measures", spec])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.output
    assert result.stderr.startswith(f"vptool: error: {message}")


def test_cli_help_shows_a_measures_example(runner):
    result = runner.invoke(main, ["measures", "--help"])
    assert result.exit_code == 0
    assert "--measures NVT,PA,I3,INS" in result.output and "'all'" in result.output


@pytest.mark.parametrize("command", [["measures"], ["sphere-map", "-o", "{tmp}/map.png"],
                                     ["best-view"]])
def test_a_mesh_of_zero_area_is_the_same_line_in_every_command(runner, tmp_path, command):
    mesh = tmp_path / "collinear.off"
    mesh.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n")
    args = [part.format(tmp=tmp_path) for part in command]
    result = runner.invoke(main, [args[0], str(mesh), *args[1:], "--views", "8",
                                  "--resolution", "16"])
    assert result.exit_code == 2, result.output
    errors = [line for line in result.stderr.splitlines() if line.startswith("vptool:")]
    assert errors == ["vptool: error: collinear: the mesh has zero surface area"]


@pytest.fixture()
def torus_cloud(tmp_path):
    """3000 points of the torus with their normals, as an (N, 6) .npy array."""
    from vptoolkit.io import load_mesh
    from vptoolkit.points import sample_surface

    sample = sample_surface(load_mesh(sample_path("torus.STL")), 3000, seed=0)
    path = tmp_path / "torus.npy"
    np.save(path, np.concatenate([sample.points, sample.normals], axis=1))
    return path


def test_measures_and_views_of_a_point_cloud(runner, torus_cloud, tmp_path):
    out = tmp_path / "torus.npz"
    result = runner.invoke(main, ["measures", str(torus_cloud), "--views", "60", "--resolution",
                                  "64", "--measures", "VE,INS,SAL", "-o", str(out)])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0].startswith("torus: 3000 points, 60 views at 64 px (raster")
    assert [line.split()[0] for line in lines[2:5]] == ["VE", "INS", "SAL"]
    with np.load(out, allow_pickle=False) as stored:
        assert stored["raw"].shape == (60, 3) and np.isfinite(stored["raw"]).all()
    result = runner.invoke(main, ["views", str(torus_cloud), "--k", "2", "--views", "60",
                                  "--resolution", "64"])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("torus: 3000 points, 60 views at 64 px, coverage objective")


def test_measures_not_defined_on_points_are_refused_for_a_cloud_in_one_line(runner, torus_cloud):
    result = runner.invoke(main, ["measures", str(torus_cloud), "--measures", "all"])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1
    assert result.stderr.startswith("vptool: error: torus: SL, SE, SC, SCE, MD, DD, SS, DVS, CE, "
                                    "MS are not defined on a point cloud")
