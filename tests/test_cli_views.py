"""vptool views, render --view-set, thumbnails --view-set and evaluate --view-sets."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from vptoolkit.cli import main
from vptoolkit.samples import sample_path

MALFORMED = Path(__file__).parent / "data" / "malformed"
SMALL = ["--views", "120", "--resolution", "96"]


@pytest.fixture()
def runner() -> CliRunner:
    return CliRunner()


def one_error_line(result) -> str:
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert lines[0].startswith("vptool: error: ")
    return lines[0]


def test_views_prints_one_row_per_pick_with_rising_coverage(runner):
    result = runner.invoke(main, ["views", str(sample_path("suzanne.ply")), *SMALL])
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
    result = runner.invoke(main, ["views", str(sample_path("teapot.stl")), *SMALL, "--k", "3",
                                  "--objective", "information", "--json", "-o", str(out)])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["objective"] == "information" and len(summary["picks"]) == 3
    with np.load(out, allow_pickle=False) as stored:
        assert stored["indices"].tolist() == [p["view_index"] for p in summary["picks"]]


def test_views_until_a_coverage_target(runner):
    result = runner.invoke(main, ["views", str(sample_path("mug.obj")), *SMALL,
                                  "--coverage", "0.9", "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    coverage = [pick["coverage"] for pick in summary["picks"]]
    assert coverage[-1] >= 0.9 * summary["reachable"] - 1e-6
    assert len(coverage) == 1 or coverage[-2] < 0.9 * summary["reachable"]


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


def test_render_view_set_draws_a_contact_sheet(runner, tmp_path):
    from fixtures.pictures import read_png

    output = tmp_path / "sheet.png"
    result = runner.invoke(main, ["render", str(sample_path("teapot.stl")), "--view-set", "3",
                                  *SMALL, "--size", "64", "-o", str(output)])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith(f"wrote {output} (3 views, views [")
    sheet = read_png(output)
    assert sheet.shape[1] == 3 * 64 + 4 * 6  # three tiles and four gaps in a row
    assert sheet.shape[0] > 64 and (sheet[..., :3] < 200).any()


def test_thumbnails_view_set_writes_a_sheet_per_mesh(runner, tmp_path):
    import shutil

    from fixtures.pictures import read_png

    source = tmp_path / "models"
    source.mkdir()
    shutil.copy(sample_path("mug.obj"), source / "mug.obj")
    (source / "broken.off").write_text("OFF\n3 1 0\n0 0 0\n")
    out = tmp_path / "sheets"
    result = runner.invoke(main, ["thumbnails", str(source), str(out), "--view-set", "2",
                                  "--size", "48", *SMALL, "--workers", "1"])
    assert result.exit_code == 1, result.output  # the broken file is skipped
    assert read_png(out / "mug.png").shape[1] == 2 * 48 + 3 * 6
    record = json.loads((out / "thumbnails.json").read_text())["thumbnails"][0]
    assert len(record["direction"]) == 2 and record["label"].startswith("view set of 2")


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
    result = runner.invoke(main, ["views", str(sample_path("mug.obj")), *SMALL, *arguments])
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
