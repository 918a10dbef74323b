"""Scoring against a dataset built with other measures than the paper's four (VE, NVT, SL):
reports, tables and JSON follow the recorded names."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fixtures.builds import THREE_MEASURES, THREE_MESHES
from fixtures.environment import require_package
from vptoolkit.cli import main
from vptoolkit.errors import InputError
from vptoolkit.evaluate.baselines import oracle_directions
from vptoolkit.evaluate.scores import evaluate_predictions
from vptoolkit.predictions import write_predictions

require_package("zarr")

def test_the_dataset_records_three_measures(three_dataset):
    assert three_dataset.measures == THREE_MEASURES and len(three_dataset) == len(THREE_MESHES)
    assert three_dataset[0]["quality"].shape == (60, 3)
    assert three_dataset[0]["best_index"].shape == (3,)


def test_the_oracle_scores_100_percent_on_every_recorded_measure(three_build, three_dataset,
                                                                 tmp_path):
    oracle = oracle_directions(three_dataset)
    assert oracle.shape == (len(THREE_MESHES), 3, 3)
    path = write_predictions(tmp_path / "oracle.npz", three_dataset.names, oracle,
                             measures=THREE_MEASURES)
    report = evaluate_predictions(three_build, path, split=None)
    assert report.measures == THREE_MEASURES and report.scored_measures == THREE_MEASURES
    assert report.scores.shape == (len(THREE_MESHES), 3)
    np.testing.assert_array_equal(report.scores, 100.0)
    lines = report.format_table().split("\n")
    assert lines[1].split() == ["category", "n", *THREE_MEASURES]
    assert lines[-1].split() == ["mean", str(len(THREE_MESHES)), "100.0", "100.0", "100.0"]
    transposed = report.format_table(transpose=True).split("\n")
    assert [line.split()[0] for line in transposed[4:]] == list(THREE_MEASURES)
    as_dict = report.to_dict(per_model=True)
    assert as_dict["measures"] == list(THREE_MEASURES)
    assert as_dict["categories"]["things"] == {"n_models": 4, "VE": 100.0, "NVT": 100.0,
                                               "SL": 100.0}
    assert list(as_dict["models"][0]) == ["name", "category", *THREE_MEASURES]


def test_a_file_naming_some_measures_in_its_own_order_is_matched_by_name(three_build, three_dataset,
                                                                         tmp_path):
    oracle = oracle_directions(three_dataset)
    reversed_names = list(reversed(three_dataset.names))
    path = write_predictions(tmp_path / "some.npz", reversed_names,
                             oracle[::-1][:, [2, 1]], measures=("SL", "NVT"))
    report = evaluate_predictions(three_build, path, split=None)
    assert report.scored_measures == ("NVT", "SL")
    assert np.isnan(report.scores[:, 0]).all()
    np.testing.assert_array_equal(report.scores[:, 1:], 100.0)
    assert report.format_table().split("\n")[-1].split()[2:] == ["-", "100.0", "100.0"]
    only = evaluate_predictions(three_build, path, split=None, measure="sl")
    assert only.scored_measures == ("SL",)
    np.save(tmp_path / "sl.npy", oracle[:, 2])
    by_row = evaluate_predictions(three_build, tmp_path / "sl.npy", split=None, measure="SL")
    np.testing.assert_array_equal(by_row.scores[:, 2], 100.0)
    np.save(tmp_path / "all.npy", oracle)
    np.testing.assert_array_equal(
        evaluate_predictions(three_build, tmp_path / "all.npy", split=None).scores, 100.0)


@pytest.mark.parametrize(("measures", "measure", "message"), [
    (("VE", "VR"), None, "1 measure not recorded in dataset.zarr: 'VR' (it records VE, NVT, SL)"),
    (("VE", "XX"), None, "unknown measure(s) 'XX'"),
    (THREE_MEASURES, "VR", "measure: measure not recorded, 'VR'; dataset.zarr records VE, NVT, SL"),
    (THREE_MEASURES, "XX", "measure: unknown measure 'XX'"),
], ids=["unrecorded", "unknown", "option-unrecorded", "option-unknown"])
def test_an_unknown_or_unrecorded_measure_is_one_line(three_build, three_dataset, tmp_path,
                                                      measures, measure, message):
    path = tmp_path / "p.npz"
    np.savez(path, names=np.array(three_dataset.names),
             directions=np.ones((len(THREE_MESHES), len(measures), 3)),
             measures=np.array(measures, dtype=str))
    with pytest.raises(InputError) as caught:
        evaluate_predictions(three_build, path, split=None, measure=measure)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_the_command_reports_the_recorded_measures(three_build, three_dataset, runner, tmp_path):
    path = write_predictions(tmp_path / "oracle.npz", three_dataset.names,
                             oracle_directions(three_dataset), measures=THREE_MEASURES)
    result = runner.invoke(main, ["evaluate", str(path), "--dataset", str(three_build), "--split",
                                  "all", "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["measures"] == list(THREE_MEASURES)
    assert report["mean"] == dict.fromkeys(THREE_MEASURES, 100.0)
    np.savez(tmp_path / "bad.npz", names=np.array(three_dataset.names),
             directions=np.ones((len(THREE_MESHES), 1, 3)), measures=np.array(["VKL"]))
    refused = runner.invoke(main, ["evaluate", str(tmp_path / "bad.npz"), "--dataset",
                                   str(three_build), "--split", "all"])
    assert refused.exit_code == 2
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and "'VKL'" in lines[0] and "not recorded" in lines[0]
