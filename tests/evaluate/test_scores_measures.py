"""Scoring against a dataset built with other measures than the paper's four (VE, NVT, SL):
reports, tables, JSON, baselines and the protocol all follow the recorded names."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from fixtures.builds import build_samples
from fixtures.environment import require_package
from vptoolkit.cli import main
from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.dataset.build.options import BuildOptions
from vptoolkit.errors import InputError
from vptoolkit.evaluate.baselines import oracle_directions, pca_directions, random_directions
from vptoolkit.evaluate.protocol import (
    best_constant_directions,
    constant_predictor,
    paired_difference,
    pca_predictor,
    random_view_scores,
    score_mesh_protocol,
    score_protocol,
)
from vptoolkit.evaluate.scores import evaluate_predictions, score_directions
from vptoolkit.predictions import write_predictions
from vptoolkit.settings import MeasureSettings

require_package("zarr")

THREE = ("VE", "NVT", "SL")
MESHES = ("bottle.obj", "mug.obj", "teapot.stl", "suzanne.ply")


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Four bundled meshes measured for VE, NVT and SL from 60 views at 48 px."""
    options = BuildOptions(MeasureSettings(views=60, resolution=48), measures=",".join(THREE),
                           n_points=300, clean=False)
    return build_samples(tmp_path_factory.mktemp("three"), MESHES, category="things",
                         options=options)


@pytest.fixture(scope="module")
def dataset(built: Path) -> Iterator[ViewpointDataset]:
    with open_dataset(built) as opened:
        yield opened


def test_the_dataset_records_three_measures(dataset):
    assert dataset.measures == THREE and len(dataset) == len(MESHES)
    assert dataset[0]["quality"].shape == (60, 3) and dataset[0]["best_index"].shape == (3,)


def test_the_oracle_scores_100_percent_on_every_recorded_measure(built, dataset, tmp_path):
    oracle = oracle_directions(dataset)
    assert oracle.shape == (len(MESHES), 3, 3)
    path = write_predictions(tmp_path / "oracle.npz", dataset.names, oracle, measures=THREE)
    report = evaluate_predictions(built, path, split=None)
    assert report.measures == THREE and report.scored_measures == THREE
    assert report.scores.shape == (len(MESHES), 3)
    np.testing.assert_array_equal(report.scores, 100.0)
    lines = report.format_table().split("\n")
    assert lines[1].split() == ["category", "n", *THREE]
    assert lines[-1].split() == ["mean", str(len(MESHES)), "100.0", "100.0", "100.0"]
    transposed = report.format_table(transpose=True).split("\n")
    assert [line.split()[0] for line in transposed[4:]] == list(THREE)
    as_dict = report.to_dict(per_model=True)
    assert as_dict["measures"] == list(THREE)
    assert as_dict["categories"]["things"] == {"n_models": 4, "VE": 100.0, "NVT": 100.0,
                                               "SL": 100.0}
    assert list(as_dict["models"][0]) == ["name", "category", *THREE]


def test_a_file_naming_some_measures_in_its_own_order_is_matched_by_name(built, dataset,
                                                                         tmp_path):
    oracle = oracle_directions(dataset)
    reversed_names = list(reversed(dataset.names))
    path = write_predictions(tmp_path / "some.npz", reversed_names,
                             oracle[::-1][:, [2, 1]], measures=("SL", "NVT"))
    report = evaluate_predictions(built, path, split=None)
    assert report.scored_measures == ("NVT", "SL")
    assert np.isnan(report.scores[:, 0]).all()
    np.testing.assert_array_equal(report.scores[:, 1:], 100.0)
    assert report.format_table().split("\n")[-1].split()[2:] == ["-", "100.0", "100.0"]
    only = evaluate_predictions(built, path, split=None, measure="sl")
    assert only.scored_measures == ("SL",)
    np.save(tmp_path / "sl.npy", oracle[:, 2])
    by_row = evaluate_predictions(built, tmp_path / "sl.npy", split=None, measure="SL")
    np.testing.assert_array_equal(by_row.scores[:, 2], 100.0)
    np.save(tmp_path / "all.npy", oracle)
    np.testing.assert_array_equal(
        evaluate_predictions(built, tmp_path / "all.npy", split=None).scores, 100.0)


@pytest.mark.parametrize(("measures", "measure", "message"), [
    (("VE", "VR"), None, "1 measure not recorded in dataset.zarr: 'VR' (it records VE, NVT, SL)"),
    (("VE", "XX"), None, "unknown measure(s) 'XX'"),
    (THREE, "VR", "measure: measure not recorded, 'VR'; dataset.zarr records VE, NVT, SL"),
    (THREE, "XX", "measure: unknown measure 'XX'"),
], ids=["unrecorded", "unknown", "option-unrecorded", "option-unknown"])
def test_an_unknown_or_unrecorded_measure_is_one_line(built, dataset, tmp_path, measures,
                                                      measure, message):
    path = tmp_path / "p.npz"
    np.savez(path, names=np.array(dataset.names),
             directions=np.ones((len(MESHES), len(measures), 3)),
             measures=np.array(measures, dtype=str))
    with pytest.raises(InputError) as caught:
        evaluate_predictions(built, path, split=None, measure=measure)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_the_command_reports_the_recorded_measures(built, dataset, runner, tmp_path):
    path = write_predictions(tmp_path / "oracle.npz", dataset.names, oracle_directions(dataset),
                             measures=THREE)
    result = runner.invoke(main, ["evaluate", str(path), "--dataset", str(built), "--split",
                                  "all", "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["measures"] == list(THREE) and report["mean"] == dict.fromkeys(THREE, 100.0)
    np.savez(tmp_path / "bad.npz", names=np.array(dataset.names),
             directions=np.ones((len(MESHES), 1, 3)), measures=np.array(["VKL"]))
    refused = runner.invoke(main, ["evaluate", str(tmp_path / "bad.npz"), "--dataset",
                                   str(built), "--split", "all"])
    assert refused.exit_code == 2
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and "'VKL'" in lines[0] and "not recorded" in lines[0]


def test_baselines_give_one_direction_per_recorded_measure(dataset):
    random = random_directions(len(dataset), seed=0, n_measures=3)
    assert random.shape == (len(MESHES), 3, 3)
    np.testing.assert_allclose(np.linalg.norm(random, axis=2), 1.0)
    assert np.isfinite(score_directions(dataset, random).scores).all()
    clouds = [dataset[i]["points"] for i in range(len(dataset))]
    pca = pca_directions(clouds, n_measures=3)
    assert pca.shape == (len(MESHES), 3, 3)
    np.testing.assert_array_equal(pca, pca[:, :1].repeat(3, axis=1))
    with pytest.raises(InputError, match="n_measures"):
        random_directions(2, seed=0, n_measures=0)


def test_the_protocol_scores_every_recorded_measure(dataset):
    expected = random_view_scores(dataset)
    assert expected.measures == THREE and expected.scores.shape == (len(MESHES), 3)
    qualities = np.stack([dataset[i]["quality"] for i in range(len(dataset))])
    np.testing.assert_allclose(expected.scores, 100.0 * qualities.mean(axis=1), rtol=1e-6)
    rotated = score_protocol(dataset, pca_predictor, n_rotations=2)
    stored = score_protocol(dataset, pca_predictor, rotate=False)
    assert rotated.measures == THREE and rotated.scores.shape == (len(MESHES), 3)
    np.testing.assert_allclose(rotated.scores, stored.scores, atol=1e-9)  # PCA turns along
    constant = best_constant_directions(dataset)
    assert constant.shape == (3, 3)
    total = qualities.sum(axis=0)
    np.testing.assert_array_equal(constant, dataset.views[total.argmax(axis=0)])
    upright = score_protocol(dataset, constant_predictor(constant), rotate=False)
    np.testing.assert_allclose(upright.mean, 100.0 * total.max(axis=0) / len(dataset),
                               atol=1e-4)
    by_mesh = score_mesh_protocol(dataset, lambda mesh: constant, n_rotations=2)
    by_points = score_protocol(dataset, constant_predictor(constant), n_rotations=2)
    np.testing.assert_allclose(by_mesh.scores, by_points.scores)
    delta, sem = paired_difference(upright, stored)
    assert delta.shape == sem.shape == (3,)
    with pytest.raises(InputError, match=r"predictor: expected directions of shape \(4, 3, 3\)"):
        score_protocol(dataset, lambda points, names: np.zeros((len(names), 4, 3)))
