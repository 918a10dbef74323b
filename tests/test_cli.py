import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from vptoolkit.cli import main
from vptoolkit.samples import sample_path

MALFORMED = Path(__file__).parent / "data" / "malformed"


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


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


def test_every_command_has_help_with_an_example(runner):
    for command in main.commands:
        result = runner.invoke(main, [command, "--help"])
        assert result.exit_code == 0 and "Example" in result.output, command


def test_clean_writes_mesh_and_report(runner, tmp_path):
    target, report = tmp_path / "bunny_clean.ply", tmp_path / "report.json"
    result = runner.invoke(main, ["clean", str(sample_path("bunny.ply")), str(target),
                                  "--max-faces", "3000", "--report", str(report)])
    assert result.exit_code == 0, result.output
    from vptoolkit.io import load_mesh

    assert load_mesh(target).n_faces <= 3000
    steps = json.loads(report.read_text())["steps"]
    assert [step["name"] for step in steps] == ["repair", "remove_hidden", "simplify"]


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


def test_pack_verify_info_on_a_small_store(runner, tmp_path):
    from fixtures.stores import write_synthetic

    store = write_synthetic(tmp_path / "dataset.zarr")
    release = tmp_path / "release"
    packed = runner.invoke(main, ["pack", str(store), str(release)])
    assert packed.exit_code == 0, packed.output
    assert (release / "SHA256SUMS").exists() and (release / "README.md").exists()
    verified = runner.invoke(main, ["verify", str(release)])
    assert verified.exit_code == 0, verified.output
    shown = runner.invoke(main, ["info", str(release), "--json"])
    assert shown.exit_code == 0
    h5 = next(release.glob("*.h5"))
    data = bytearray(h5.read_bytes())
    data[len(data) // 2] ^= 0xFF
    h5.write_bytes(bytes(data))
    broken = runner.invoke(main, ["verify", str(release)])
    assert broken.exit_code == 1 and h5.name in broken.stderr


def test_evaluate_scores_the_oracle_at_100_and_rejects_bad_files(runner, tmp_path):
    from fixtures.stores import write_synthetic
    from vptoolkit.data import open_dataset
    from vptoolkit.evaluate.baselines import oracle_directions

    store = write_synthetic(tmp_path / "dataset.zarr")
    with open_dataset(store) as dataset:
        test = dataset.split("test")
        np.save(tmp_path / "oracle.npy", oracle_directions(test))
        n_test = len(test)
    result = runner.invoke(main, ["evaluate", str(tmp_path / "oracle.npy"), "--dataset",
                                  str(store), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["mean"] == {m: 100.0 for m in ("VE", "VR", "VKL", "VMI")}
    np.save(tmp_path / "bad.npy", np.zeros((n_test, 4, 3)))
    bad = runner.invoke(main, ["evaluate", str(tmp_path / "bad.npy"), "--dataset", str(store)])
    assert bad.exit_code == 2 and bad.stderr.startswith("vptool: error: bad.npy: ")


def test_build_dataset_records_failures_and_exits_1(runner, tmp_path):
    import shutil

    src = tmp_path / "src"
    (src / "things").mkdir(parents=True)
    for name in ("teapot.stl", "suzanne.ply"):
        shutil.copy(sample_path(name), src / "things" / name)
    shutil.copy(MALFORMED / "empty.obj", src / "things" / "empty.obj")
    result = runner.invoke(main, ["build-dataset", str(src), str(tmp_path / "out"), "--views", "40",
                                  "--resolution", "48", "--points", "200", "--no-clean"])
    assert result.exit_code == 1, result.output
    assert "2 models, 1 failures" in result.stdout
    assert "failed things/empty.obj: " in result.stderr
    shown = runner.invoke(main, ["info", str(tmp_path / "out")])
    assert shown.exit_code == 0 and "things" in shown.stdout


@pytest.mark.slow
def test_train_predict_evaluate_from_the_command_line(runner, tmp_path):
    import shutil

    from vptoolkit.synthetic import write_collection

    src = tmp_path / "shapes"
    write_collection(src, n_per_category=3, categories=("bottle", "table"), seed=0)
    out = tmp_path / "out"
    built = runner.invoke(main, ["build-dataset", str(src), str(out), "--views", "60",
                                 "--resolution", "48", "--points", "1500", "--no-clean",
                                 "--split-seed", "3"])
    assert built.exit_code == 0, built.output
    model = tmp_path / "model.safetensors"
    trained = runner.invoke(main, ["train", str(out), "-o", str(model), "--epochs", "2",
                                   "--batch-size", "2", "--threads", "1", "--val-split", "train"])
    assert trained.exit_code == 0, trained.output
    assert model.exists() and model.with_suffix(".json").exists()
    predictions = tmp_path / "predictions.npz"
    predicted = runner.invoke(main, ["predict", "--model", str(model), "--dataset", str(out),
                                     "--split", "all", "-o", str(predictions)])
    assert predicted.exit_code == 0, predicted.output
    with np.load(predictions, allow_pickle=False) as stored:
        assert stored["directions"].shape == (6, 4, 3)
    scored = runner.invoke(main, ["evaluate", str(predictions), "--dataset", str(out),
                                  "--split", "all", "--json"])
    assert scored.exit_code == 0, scored.output
    assert set(json.loads(scored.stdout)["mean"]) == {"VE", "VR", "VKL", "VMI"}
    mesh_prediction = runner.invoke(main, ["predict", "--model", str(model),
                                           str(sample_path("teapot.stl")),
                                           "-o", str(tmp_path / "teapot.npz"), "--device", "cpu"])
    assert mesh_prediction.exit_code == 0, mesh_prediction.output

    per_category = tmp_path / "per_category"
    trained = runner.invoke(main, ["train", str(out), "-o", str(per_category), "--per-category",
                                   "--epochs", "1", "--batch-size", "2", "--threads", "1",
                                   "--val-split", "train",
                                   "--device", "cpu"])
    assert trained.exit_code == 0, trained.output
    assert trained.stdout.startswith("bottle: best epoch 1 of 1")
    assert "table: best epoch" in trained.stdout
    routed = runner.invoke(main, ["predict", "--model", str(per_category), "--dataset", str(out),
                                  "--split", "all"])
    assert routed.exit_code == 0, routed.output
    unrouted = runner.invoke(main, ["predict", "--model", str(per_category),
                                    str(sample_path("teapot.stl"))])
    assert unrouted.exit_code == 2 and "one network per category" in unrouted.stderr
    chosen = runner.invoke(main, ["predict", "--model", str(per_category),
                                  str(sample_path("teapot.stl")), "--category", "table"])
    assert chosen.exit_code == 0, chosen.output
    shutil.rmtree(out)
