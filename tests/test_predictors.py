"""Predictors behind one call: the occlusion-free one over files and datasets, and by name."""

import numpy as np
import pytest
from click.testing import CliRunner

from vptoolkit.cli import main
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.measures.unoccluded import unoccluded_best_views
from vptoolkit.mesh import Mesh
from vptoolkit.points import sample_surface
from vptoolkit.predictions import Predictions, read_predictions
from vptoolkit.predictors import predict_unoccluded, resolve_predictor
from vptoolkit.samples import sample_path


@pytest.fixture(scope="module")
def teapot() -> Mesh:
    return load_mesh(sample_path("teapot.stl"))


def test_predict_unoccluded_of_a_mesh_a_scan_and_a_dataset(tmp_path, tiny_dataset, teapot):
    sample = sample_surface(teapot, 3000, seed=0)
    scan = tmp_path / "scan.npy"
    np.save(scan, np.hstack([sample.points, sample.normals]))
    out = tmp_path / "best.npz"
    result = CliRunner().invoke(main, ["predict", "--model", "unoccluded",
                                       str(sample_path("teapot.stl")), str(scan), "--dataset",
                                       str(tiny_dataset), "--split", "all", "-o", str(out)])
    assert result.exit_code == 0, result.output
    names, directions, measures = read_predictions(out)
    assert list(names[:2]) == ["teapot", "scan"] and len(names) == 6
    assert directions.shape == (6, 4, 3) and list(measures) == list(PAPER_MEASURES)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=2), 1.0)
    np.testing.assert_array_equal(directions[1], unoccluded_best_views(sample.normals))
    only_dataset = tmp_path / "dataset.npz"
    assert CliRunner().invoke(main, ["predict", "-m", "unoccluded", "--dataset",
                                     str(tiny_dataset), "--split", "all",
                                     "-o", str(only_dataset)]).exit_code == 0
    scored = CliRunner().invoke(main, ["evaluate", str(only_dataset), "--dataset",
                                       str(tiny_dataset), "--split", "all"])
    assert scored.exit_code == 0, scored.output


def test_predict_unoccluded_of_points_without_normals_exits_2(tmp_path, teapot):
    scan = tmp_path / "bare.npy"
    np.save(scan, sample_surface(teapot, 500, seed=0).points)
    result = CliRunner().invoke(main, ["predict", "--model", "unoccluded", str(scan)])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and "bare.npy: has no normals" in result.stderr
    assert "Traceback" not in result.output


def test_predict_unoccluded_of_normals_longer_than_1e154_is_the_unit_answer(tmp_path, teapot):
    sample = sample_surface(teapot, 2000, seed=0)
    unit, huge = tmp_path / "unit.npy", tmp_path / "huge.npy"
    np.save(unit, np.hstack([sample.points, sample.normals]))
    np.save(huge, np.hstack([sample.points, sample.normals * 1e155]))
    outputs = [CliRunner().invoke(main, ["predict", "-m", "unoccluded", str(path)])
               for path in (unit, huge)]
    assert [outcome.exit_code for outcome in outputs] == [0, 0], outputs[1].output
    assert outputs[1].stderr == ""
    assert outputs[1].stdout.replace("huge:", "unit:") == outputs[0].stdout


@pytest.mark.parametrize("stored, message", [
    (0.0, "model 'airplane_0001': 200 of 200 normals have zero length"),
    (np.nan, "model 'airplane_0001': a normal is NaN or infinite"),
])
def test_predict_unoccluded_of_broken_stored_normals_names_the_dataset_and_model(
        tmp_path, stored, message):
    import h5py

    from fixtures.stores import N_POINTS, write_synthetic

    store = write_synthetic(tmp_path / "dataset.h5")
    with h5py.File(store, "r+") as handle:  # damaged after writing, as on a bad disk
        handle["normals"][0] = np.full((N_POINTS, 3), stored)
    result = CliRunner().invoke(main, ["predict", "-m", "unoccluded", "--dataset", str(store),
                                       "--split", "all"])
    assert result.exit_code == 2, result.output
    assert result.stderr == f"vptool: error: {store}: {message}\n"


def test_resolve_predictor_by_name_and_as_given(tiny_dataset):
    unoccluded = resolve_predictor("unoccluded")
    answered = unoccluded([sample_path("teapot.stl"), tiny_dataset], split=None)
    assert answered.names[0] == "teapot" and answered.measures == PAPER_MEASURES
    np.testing.assert_array_equal(answered.directions,
                                  predict_unoccluded([sample_path("teapot.stl"), tiny_dataset],
                                                     split=None).directions)

    def constant(inputs, *, split="test") -> Predictions:
        return Predictions(("a",), np.ones((1, 1, 3)), ("VE",))

    assert resolve_predictor(constant) is constant
    with pytest.raises(InputError) as refused:
        resolve_predictor(3)  # type: ignore[arg-type]
    assert str(refused.value) == ("model: expected one of 'default', 'points', 'unoccluded', a "
                                  "checkpoint path or a callable, got 3")
    with pytest.raises(InputError, match="n_inputs: 'unoccluded' asks no network"):
        resolve_predictor("unoccluded", n_inputs=4)


def test_predict_unoccluded_answers_the_measures_asked_in_their_order(teapot):
    both = predict_unoccluded(sample_path("teapot.stl"), measures="VKL,VE")
    every = predict_unoccluded(sample_path("teapot.stl"))
    assert both.measures == ("VKL", "VE")
    np.testing.assert_array_equal(both.directions[0], every.directions[0][[2, 0]])
    with pytest.raises(InputError, match="no closed form for SL"):
        predict_unoccluded(sample_path("teapot.stl"), measures="SL")
