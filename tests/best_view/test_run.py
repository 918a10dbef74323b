"""Best views of many inputs as vptool best-view runs them: mesh files, a dataset split,
failures, and the predictions evaluate reads."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from vptoolkit.best_view.run import search_inputs
from vptoolkit.best_view.search import SearchSettings
from vptoolkit.cli import main
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.predictions import read_predictions
from vptoolkit.samples import sample_path


def test_a_batch_records_failures_and_carries_on(tmp_path):
    broken = tmp_path / "broken.off"
    broken.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n")
    run = search_inputs([sample_path("mug.obj"), broken],
                        settings=SearchSettings(budget=8, resolution=32))
    assert [result.name for result in run.results] == ["mug"]
    assert len(run.failures) == 1 and run.failures[0][0] == str(broken)
    assert "broken.off" in run.failures[0][1] and "\n" not in run.failures[0][1]


def test_command_writes_predictions_evaluate_reads(tmp_path):
    out = tmp_path / "best.npz"
    runner = CliRunner()
    arguments = ["best-view", str(sample_path("mug.obj")), str(sample_path("teapot.stl")),
                 "--views", "16", "--resolution", "64", "-o", str(out)]
    result = runner.invoke(main, arguments)
    assert result.exit_code == 0, result.output
    assert "mug: 16 views (" in result.stdout and f"wrote {out} (2 meshes)" in result.stdout
    names, directions, measures = read_predictions(out)
    assert list(names) == ["mug", "teapot"] and directions.shape == (2, 4, 3)
    assert tuple(measures) == PAPER_MEASURES
    first = out.read_bytes()
    assert runner.invoke(main, arguments).exit_code == 0 and out.read_bytes() == first


def test_command_json_lists_directions_views_resolutions_and_seconds():
    result = CliRunner().invoke(main, ["best-view", str(sample_path("mug.obj")), "--views", "8",
                                       "--resolution", "48", "--json"])
    assert result.exit_code == 0, result.output
    entry = json.loads(result.stdout)["results"][0]
    assert entry["file"] == str(sample_path("mug.obj")) and entry["dataset"] is None
    assert entry["name"] == "mug"
    assert entry["views"] == 8 and entry["resolution"] == 48 and entry["seconds"] > 0
    assert sum(stage["views"] for stage in entry["stages"]) == 8
    assert set(entry["best"]) == set(PAPER_MEASURES)


@pytest.mark.parametrize("arguments, message", [
    (["--views", "0"], "--views"),
    (["--resolution", "0"], "--resolution"),
    (["--prior", "no/such/model"], "no/such/model"),
    (["-o", "out.txt"], "out.txt"),
])
def test_command_bad_budgets_resolutions_and_priors_exit_2(arguments, message):
    result = CliRunner().invoke(main, ["best-view", str(sample_path("mug.obj")), *arguments])
    assert result.exit_code == 2, result.output
    assert result.stderr.count("\n") == 1 and message in result.stderr
    assert "Traceback" not in result.output


def test_command_without_inputs_exits_2():
    result = CliRunner().invoke(main, ["best-view"])
    assert result.exit_code == 2 and "give mesh files, a collection" in result.stderr


def test_command_reports_a_failed_mesh_and_exits_1(tmp_path):
    broken = tmp_path / "broken.off"
    broken.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n")
    result = CliRunner().invoke(main, ["best-view", str(sample_path("mug.obj")), str(broken),
                                       "--views", "8", "--resolution", "32"])
    assert result.exit_code == 1
    assert "mug: 8 views" in result.stdout
    assert "broken.off" in result.stderr and "1 of 2 inputs failed" in result.stderr


def test_command_on_a_dataset_split_is_scored_by_evaluate(tmp_path):
    import shutil

    from vptoolkit.data import open_dataset

    src = tmp_path / "src" / "things"
    src.mkdir(parents=True)
    for name in ("teapot.stl", "mug.obj", "suzanne.ply"):
        shutil.copy(sample_path(name), src / name)
    runner = CliRunner()
    built = runner.invoke(main, ["build-dataset", str(src.parent), str(tmp_path / "out"),
                                 "--views", "100", "--resolution", "48", "--points", "200",
                                 "--no-clean"])
    assert built.exit_code == 0, built.output
    out = tmp_path / "best.npz"
    searched = runner.invoke(main, ["best-view", "--dataset", str(tmp_path / "out"), "--split",
                                    "all", "--views", "32", "--resolution", "48", "-o", str(out)])
    assert searched.exit_code == 0, searched.output
    scored = runner.invoke(main, ["evaluate", str(out), "--dataset", str(tmp_path / "out"),
                                  "--split", "all", "--json"])
    assert scored.exit_code == 0, scored.output
    mean = json.loads(scored.stdout)["mean"]
    with open_dataset(tmp_path / "out") as dataset:
        random_view = np.mean([dataset[i]["quality"].mean(axis=0) for i in range(len(dataset))],
                              axis=0)
    assert all(mean[m] > 100 * random_view[i] + 10 for i, m in enumerate(PAPER_MEASURES))


@pytest.mark.parametrize("text, message", [
    ("OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 7\n",
     "bad.off: face 0 refers to vertex 7"),
    ("OFF\n4 2 0\n0 0 0\n1 0 0\n2 0 0\n3 0 0\n3 0 1 2\n3 1 2 3\n",
     "bad: the mesh has zero surface area"),
], ids=["bad-index", "zero-area"])
@pytest.mark.parametrize("prior", ["none", "unoccluded"])
def test_command_on_one_bad_mesh_is_one_line_and_exit_2(tmp_path, text, message, prior):
    bad = tmp_path / "bad.off"
    bad.write_text(text)
    result = CliRunner().invoke(main, ["best-view", str(bad), "--views", "8", "--resolution",
                                       "32", "--prior", prior])
    assert result.exit_code == 2, result.output
    lines = result.stderr.replace("\r", "\n").splitlines()  # the progress bar aside
    errors = [line for line in lines if not line.startswith("best views:") and line.strip()]
    assert len(errors) == 1 and errors[0].startswith(f"vptool: error: {message}"), lines
    assert "Traceback" not in result.output and "Warning" not in result.output


def test_command_on_an_empty_split_is_one_line_and_exit_2(tmp_path):
    from fixtures.stores import synthetic_entries, write_synthetic

    store = write_synthetic(tmp_path / "dataset.zarr", synthetic_entries(
        [("chair", "chair_0001", "train"), ("chair", "chair_0002", "train")]))
    out = tmp_path / "best.npz"
    result = CliRunner().invoke(main, ["best-view", "--dataset", str(store), "--split", "test",
                                       "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert result.stderr == (f"vptool: error: {store}: split 'test' holds no models; "
                             "nothing to search\n")
    assert not out.exists()
