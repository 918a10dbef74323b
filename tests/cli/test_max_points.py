"""--max-points: a cloud over the limit is answered as its voxel-thinned subset, warned once."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest

from vptoolkit.cli import main
from vptoolkit.io import load
from vptoolkit.point_cloud import voxel_subset
from vptoolkit.points import sample_surface
from vptoolkit.predictions import Predictions
from vptoolkit.samples import sample_path

SMALL = ["--views", "8", "--resolution", "32"]
LIMIT = "5000"


@pytest.fixture()
def clouds(tmp_path: Path) -> tuple[Path, Path]:
    """``dense/dense.npy``: 50,000 points and normals on the bunny; ``thin/dense.npy``: its
    rows that :func:`voxel_subset` keeps for 5000 (the same name, so the answers compare)."""
    sample = sample_surface(load(sample_path("bunny.ply")), 50_000, seed=0)
    rows = np.hstack([sample.points, sample.normals])
    dense, thin = tmp_path / "dense" / "dense.npy", tmp_path / "thin" / "dense.npy"
    dense.parent.mkdir()
    thin.parent.mkdir()
    np.save(dense, rows)
    kept = voxel_subset(sample.points, int(LIMIT))
    assert len(kept) < len(rows)
    np.save(thin, rows[kept])
    return dense, thin


def _warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [record.getMessage() for record in caplog.records
            if "more than max_points" in record.getMessage()]


def test_best_view_answers_the_thinned_cloud_and_warns_once(runner, clouds, tmp_path, caplog):
    dense, thin = clouds
    with caplog.at_level(logging.WARNING):
        result = runner.invoke(main, ["best-view", str(dense), *SMALL, "--max-points", LIMIT,
                                      "-o", str(tmp_path / "dense.npz")])
    assert result.exit_code == 0, result.output
    [warning] = _warnings(caplog)
    kept = len(np.load(thin))
    assert warning == (f"dense.npy: 50,000 points, more than max_points=5,000; kept {kept:,}, "
                       "one per voxel (vptoolkit.point_cloud.voxel_subset)")
    result = runner.invoke(main, ["best-view", str(thin), *SMALL,
                                  "-o", str(tmp_path / "thin.npz")])
    assert result.exit_code == 0, result.output
    thinned = Predictions.load_npz(tmp_path / "dense.npz")
    expected = Predictions.load_npz(tmp_path / "thin.npz")
    assert thinned.names == expected.names == ("dense",)
    np.testing.assert_array_equal(thinned.directions, expected.directions)


def test_measures_answers_the_thinned_cloud(runner, clouds):
    dense, thin = clouds
    answers = []
    for arguments in ([str(dense), "--max-points", LIMIT], [str(thin)]):
        result = runner.invoke(main, ["measures", *arguments, *SMALL, "--json"])
        assert result.exit_code == 0, result.output
        summary = json.loads(result.stdout)
        summary.pop("seconds")
        answers.append(summary)
    assert answers[0] == answers[1]
    assert answers[0]["n_faces"] == len(np.load(thin))


@pytest.mark.parametrize("model", ["unoccluded", "points"])
def test_predict_answers_the_thinned_cloud_and_warns_once(runner, clouds, model, caplog):
    dense, thin = clouds
    with caplog.at_level(logging.WARNING):
        result = runner.invoke(main, ["predict", "--model", model, str(dense), "--json",
                                      "--max-points", LIMIT, "--device", "cpu"])
    assert result.exit_code == 0, result.output
    assert len(_warnings(caplog)) == 1  # read for the check, the answer and the poses
    expected = runner.invoke(main, ["predict", "--model", model, str(thin), "--json",
                                    "--device", "cpu"])
    assert expected.exit_code == 0, expected.output
    assert json.loads(result.stdout) == {
        "results": [{**record, "file": str(dense)}
                    for record in json.loads(expected.stdout)["results"]]}


def test_a_collection_with_max_points_is_answered_into_another_settings_folder(
        runner, clouds, tmp_path):
    dense, thin = clouds
    out = tmp_path / "views"
    tables = []
    for extra in ([], ["--max-points", LIMIT]):
        result = runner.invoke(main, ["best-view", str(dense.parent), "-o", str(out), *SMALL,
                                      *extra])
        assert result.exit_code == 0, result.output
        tables.append(Path(result.stdout.rstrip().rsplit(": ", 1)[1]))
    default, limited = tables
    assert default.parent != limited.parent and default.parent.parent == out
    assert "max_points" not in json.loads((default.parent / "settings.json").read_text())
    assert json.loads((limited.parent / "settings.json").read_text())["max_points"] == 5000
    thin_out = runner.invoke(main, ["best-view", str(thin.parent), "-o", str(tmp_path / "thin"),
                                    *SMALL])
    assert thin_out.exit_code == 0, thin_out.output
    thin_table = Path(thin_out.stdout.rstrip().rsplit(": ", 1)[1])
    np.testing.assert_array_equal(
        Predictions.load_npz(limited.parent / "predictions.npz").directions,
        Predictions.load_npz(thin_table.parent / "predictions.npz").directions)


@pytest.mark.parametrize("value", ["0", "-3", "2.5", "many"])
def test_a_bad_max_points_is_one_line_and_exit_2(runner, clouds, value):
    result = runner.invoke(main, ["measures", str(clouds[0]), "--max-points", value])
    assert result.exit_code == 2
    [line] = result.stderr.splitlines()
    assert line.startswith("vptool: error: measures: Invalid value for '--max-points': ")


@pytest.mark.parametrize("command", ["best-view", "measures", "views", "sphere-map", "render",
                                     "thumbnails", "predict", "build-dataset"])
def test_every_command_that_reads_clouds_lists_max_points(runner, command):
    result = runner.invoke(main, [command, "--help"])
    assert result.exit_code == 0, result.output
    assert "--max-points" in result.stdout and "20000000" in result.stdout
