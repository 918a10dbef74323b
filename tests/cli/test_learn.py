"""vptool train, predict and evaluate."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.paths import MALFORMED
from vptoolkit.cli import main
from vptoolkit.samples import sample_path


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


def test_train_refuses_unknown_point_features_before_any_work(runner, tmp_path):
    result = runner.invoke(main, ["train", str(tmp_path / "missing"), "-o", str(tmp_path / "m"),
                                  "--point-features", "face_area,curvature"])
    assert result.exit_code == 2
    assert result.stderr == ("vptool: error: --point-features: unknown ['curvature'], expected "
                             "names of ['face_area', 'normal', 'spacing_area', "
                             "'estimated_normal']\n")
    assert not (tmp_path / "m").exists()


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
    record = json.loads(model.with_suffix(".json").read_text())
    assert record["architecture"]["point_features"] == ["face_area"]
    plain = tmp_path / "plain.safetensors"
    trained_plain = runner.invoke(main, ["train", str(out), "-o", str(plain), "--epochs", "1",
                                         "--batch-size", "2", "--threads", "1", "--val-split",
                                         "train", "--point-features", "none"])
    assert trained_plain.exit_code == 0, trained_plain.output
    assert json.loads(plain.with_suffix(".json").read_text())["architecture"][
        "point_features"] == []
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


def test_predict_with_the_bundled_network_prints_directions(runner):
    require_package("torch")
    result = runner.invoke(main, ["predict", str(sample_path("bunny.ply"))])
    assert result.exit_code == 0, result.output
    line = result.stdout.strip().splitlines()[0]
    assert line.startswith("bunny: VE (") and "VMI (" in line


def _refuse(constant: str) -> None:
    raise ValueError(f"not JSON: {constant}")


def _check_answer_record(record: dict, measures: tuple[str, ...]) -> None:
    """The cameras of a ``--json`` record look along its directions from 1024 px images."""
    assert record["resolution"] == 1024 and record["up"] == [0.0, 1.0, 0.0]
    focal = record["intrinsics"][0][0]
    assert record["intrinsics"] == [[focal, 0.0, 512.0], [0.0, focal, 512.0], [0.0, 0.0, 1.0]]
    assert list(record["best"]) == list(measures)
    for best in record["best"].values():
        pose = np.array(best["pose"])
        assert pose.shape == (4, 4) and pose[3].tolist() == [0.0, 0.0, 0.0, 1.0]
        np.testing.assert_allclose(np.linalg.norm(best["direction"]), 1.0, atol=1e-5)
        # OpenCV: the camera's z axis looks at the model, against the direction
        np.testing.assert_allclose(pose[:3, 2], -np.array(best["direction"]), atol=1e-5)
        np.testing.assert_allclose(pose[:3, :3] @ pose[:3, :3].T, np.eye(3), atol=1e-9)


def test_predict_json_is_one_record_per_model_with_cameras(runner, tmp_path, tiny_dataset):
    from vptoolkit.measures.registry import PAPER_MEASURES
    from vptoolkit.predictions import read_predictions

    out = tmp_path / "best.npz"
    mug = str(sample_path("mug.obj"))
    result = runner.invoke(main, ["predict", "-m", "unoccluded", mug, "--dataset",
                                  str(tiny_dataset), "--split", "all", "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    records = json.loads(result.stdout, parse_constant=_refuse)["results"]  # stdout: JSON alone
    names, directions, _ = read_predictions(out)
    assert [record["name"] for record in records] == list(names) and len(records) == 5
    assert [(record["file"], record["dataset"]) for record in records] == (
        [(mug, None)] + [(None, str(tiny_dataset))] * 4)
    for record, answer in zip(records, directions):
        assert record["predictor"] == "unoccluded"
        _check_answer_record(record, PAPER_MEASURES)
        np.testing.assert_allclose([best["direction"] for best in record["best"].values()],
                                   answer, atol=1e-6)
    # the same record as best-view --json prints for its answer: the eye is in model units
    from vptoolkit.best_view.answer import answer_record
    from vptoolkit.camera import Camera
    from vptoolkit.io import load_mesh

    poses = Camera().look_at(load_mesh(mug), directions[0], resolution=1024)
    expected = json.loads(json.dumps(answer_record(PAPER_MEASURES, directions[0], poses)))
    assert {key: records[0][key] for key in expected} == expected


def test_predict_json_of_the_bundled_network_and_of_bad_input(runner):
    require_package("torch")
    result = runner.invoke(main, ["predict", str(sample_path("mug.obj")), "--inputs", "1",
                                  "--device", "cpu", "--json"])
    assert result.exit_code == 0, result.output
    (record,) = json.loads(result.stdout, parse_constant=_refuse)["results"]
    assert (record["name"], record["predictor"], record["dataset"]) == ("mug", "default", None)
    assert "VE" in record["best"]
    _check_answer_record(record, tuple(record["best"]))
    refused = runner.invoke(main, ["predict", str(MALFORMED / "empty.obj"), "--json"])
    assert refused.exit_code == 2 and refused.stdout == ""
    # the one error line ends stderr, after the bar the network's input draws had begun
    errors = [line for line in refused.stderr.splitlines() if "error" in line]
    assert errors == [refused.stderr.splitlines()[-1]], refused.stderr
    assert errors[0].startswith("vptool: error: empty.obj: ")


def test_predict_asks_the_network_about_as_many_inputs_as_told(runner, tmp_path):
    require_package("torch")
    from vptoolkit.cli.learn import predict_command
    from vptoolkit.learn.draws import N_INPUTS
    from vptoolkit.learn.predict import predict

    mug = sample_path("mug.obj")
    found = {}
    for n_inputs in (1, 16):
        written = tmp_path / f"mug{n_inputs}.npz"
        result = runner.invoke(main, ["predict", str(mug), "--inputs", str(n_inputs),
                                      "--device", "cpu", "-o", str(written)])
        assert result.exit_code == 0, result.output
        with np.load(written, allow_pickle=False) as stored:
            found[n_inputs] = stored["directions"]
        expected = predict("default", mug, n_inputs=n_inputs, device="cpu").directions
        np.testing.assert_allclose(found[n_inputs], expected, rtol=0, atol=1e-5)
    # the command changes what the library changes: one input or the consensus of sixteen
    api_same = np.allclose(predict("default", mug, n_inputs=1, device="cpu").directions,
                           predict("default", mug, n_inputs=16, device="cpu").directions)
    assert np.allclose(found[1], found[16]) == api_same
    # no --inputs is the library's default, which the help states without importing torch
    plain = runner.invoke(main, ["predict", str(mug), "--device", "cpu",
                                 "-o", str(tmp_path / "plain.npz")])
    assert plain.exit_code == 0, plain.output
    with np.load(tmp_path / "plain.npz", allow_pickle=False) as stored:
        np.testing.assert_array_equal(stored["directions"], found[N_INPUTS])
    option = next(param for param in predict_command.params if param.name == "n_inputs")
    assert option.show_default == str(N_INPUTS)
    for bad in (["--inputs", "0"], ["--inputs", "65"], ["--inputs", "2", "-m", "unoccluded"]):
        refused = runner.invoke(main, ["predict", str(mug), *bad])
        assert refused.exit_code == 2 and refused.stdout == ""
        assert refused.stderr.startswith("vptool: error: ") and "--inputs" in refused.stderr
        assert refused.stderr.count("\n") == 1, refused.stderr
