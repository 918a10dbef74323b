"""Nearest-sample scoring of predicted viewpoints and the prediction files it reads, also
against a dataset built with other measures than the paper's four."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from fixtures.builds import THREE_MEASURES, THREE_MESHES
from fixtures.environment import require_package
from fixtures.stores import SCORED_ENTRIES, SCORED_MODELS, synthetic_entry, write_synthetic
from vptoolkit.cli import main
from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.errors import InputError
from vptoolkit.evaluate.baselines import oracle_directions, random_directions
from vptoolkit.evaluate.scores import (
    EvaluationReport,
    evaluate_predictions,
    load_predictions,
    score_directions,
)
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.predictions import write_predictions
from vptoolkit.predictions import write_predictions as save_predictions

TEST_NAMES = [name for _, name, split in SCORED_MODELS if split == "test"]

QUALITY = {entry.name: np.asarray(entry.quality, np.float32) for entry in SCORED_ENTRIES}


@pytest.fixture(scope="module")
def test_split(scored_dataset: ViewpointDataset) -> ViewpointDataset:
    return scored_dataset.split("test")


def fixed_view_directions(split: ViewpointDataset, view_of_measure: list[int]) -> np.ndarray:
    """Directions pointing at given sampled views (scaled, so not unit length)."""
    return np.stack([3.0 * split.views[view_of_measure]] * len(split))


def test_oracle_scores_100_percent(scored_store: Path, test_split: ViewpointDataset,
                                   tmp_path: Path) -> None:
    oracle = oracle_directions(test_split)
    assert oracle.shape == (len(TEST_NAMES), 4, 3) and oracle.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(oracle, axis=2), 1.0)
    path = save_predictions(tmp_path / "oracle.npz", test_split.names, oracle)
    report = evaluate_predictions(scored_store, path)
    assert (report.split, report.dataset, report.predictions) == ("test", "dataset.zarr",
                                                                  "oracle.npz")
    assert report.names == tuple(TEST_NAMES)
    np.testing.assert_array_equal(report.scores, 100.0)
    np.testing.assert_array_equal(report.category_scores, 100.0)
    np.testing.assert_array_equal(report.mean, 100.0)
    assert report.scored_measures == PAPER_MEASURES


def test_random_directions_score_the_mean_quality(scored_dataset: ViewpointDataset) -> None:
    n_seeds = 50
    scores = np.stack([score_directions(scored_dataset,
                                        random_directions(len(scored_dataset), seed=seed)).scores
                       for seed in range(n_seeds)])  # (seeds, models, 4)
    view_means = np.stack([QUALITY[name].mean(axis=0)
                           for name in scored_dataset.names])  # (models, 4)
    spread = np.mean([QUALITY[name].std(axis=0) for name in scored_dataset.names])
    n_samples = scores.size
    tolerance = 4.0 * 100.0 * spread / math.sqrt(n_samples)
    assert abs(scores.mean() - 100.0 * view_means.mean()) < tolerance
    # per measure too, with the tolerance for a quarter of the samples
    np.testing.assert_allclose(scores.mean(axis=(0, 1)), 100.0 * view_means.mean(axis=0),
                               atol=2.0 * tolerance)


def test_category_means_and_the_mean_over_categories(test_split: ViewpointDataset) -> None:
    views = [7, 0, 23, 49]
    report = score_directions(test_split, fixed_view_directions(test_split, views))
    expected = {name: 100.0 * QUALITY[name][views, np.arange(4)] for name in TEST_NAMES}
    np.testing.assert_allclose(report.scores, np.stack([expected[n] for n in TEST_NAMES]),
                               rtol=1e-6)
    assert report.categories == ("airplane", "chair", "table")
    np.testing.assert_array_equal(report.category_counts, [3, 1, 2])
    by_category = np.stack([
        np.mean([expected[n] for n in TEST_NAMES if n.startswith(category)], axis=0)
        for category in report.categories
    ])
    np.testing.assert_allclose(report.category_scores, by_category, rtol=1e-6)
    np.testing.assert_allclose(report.mean, by_category.mean(axis=0), rtol=1e-6)
    np.testing.assert_allclose(report.model_mean, report.scores.mean(axis=0), rtol=1e-6)
    assert not np.allclose(report.mean, report.model_mean)  # uneven categories
    assert report.split == "test" and report.predictions == "<array>"
    assert not report.scores.flags.writeable


def test_report_shapes(test_split: ViewpointDataset) -> None:
    report = score_directions(test_split, oracle_directions(test_split))
    assert isinstance(report, EvaluationReport)
    assert report.scores.shape == (6, 4) and report.scores.dtype == np.float64
    assert report.category_scores.shape == (3, 4) and report.category_counts.dtype == np.int64
    assert report.mean.shape == (4,) and report.model_mean.shape == (4,)
    assert report.is_scored.shape == (4,) and report.measures == PAPER_MEASURES


@pytest.fixture(scope="module")
def reference(test_split: ViewpointDataset) -> tuple[np.ndarray, EvaluationReport]:
    directions = random_directions(len(test_split), seed=7) * 2.5
    return directions, score_directions(test_split, directions, split="test")


def test_npy_with_four_measures_matches_npz(scored_store: Path, tmp_path: Path,
                                            reference: tuple[np.ndarray, EvaluationReport]
                                            ) -> None:
    directions, expected = reference
    np.save(tmp_path / "predictions.npy", directions.astype(np.float32))
    report = evaluate_predictions(scored_store, tmp_path / "predictions.npy")
    np.testing.assert_allclose(report.scores, expected.scores)
    assert report.predictions == "predictions.npy"


def test_npz_is_matched_by_name(scored_store: Path, tmp_path: Path,
                                reference: tuple[np.ndarray, EvaluationReport]) -> None:
    directions, expected = reference
    order = np.random.default_rng(3).permutation(len(TEST_NAMES))
    assert (order != np.arange(len(order))).any()
    path = save_predictions(tmp_path / "shuffled.npz", [TEST_NAMES[i] for i in order],
                            directions[order])
    report = evaluate_predictions(scored_store, path)
    assert report.names == tuple(TEST_NAMES)
    np.testing.assert_array_equal(report.scores, expected.scores)
    names, loaded = load_predictions(path, open_dataset(scored_store).split("test"))
    assert names == TEST_NAMES
    np.testing.assert_array_equal(loaded, directions)


@pytest.mark.parametrize("measure", PAPER_MEASURES)
def test_npy_single_measure(scored_store: Path, tmp_path: Path, measure: str,
                            reference: tuple[np.ndarray, EvaluationReport]) -> None:
    directions, expected = reference
    column = PAPER_MEASURES.index(measure)
    np.save(tmp_path / "one.npy", directions[:, column])
    report = evaluate_predictions(scored_store, tmp_path / "one.npy", measure=measure.lower())
    assert report.scored_measures == (measure,)
    np.testing.assert_array_equal(report.scores[:, column], expected.scores[:, column])
    assert np.isnan(np.delete(report.scores, column, axis=1)).all()
    assert report.to_dict()["mean"] == {
        m: (float(expected.mean[column]) if m == measure else None) for m in PAPER_MEASURES}


def test_measure_restricts_a_full_prediction(scored_store: Path, tmp_path: Path,
                                             reference: tuple[np.ndarray, EvaluationReport]
                                             ) -> None:
    directions, expected = reference
    path = save_predictions(tmp_path / "all.npz", TEST_NAMES, directions)
    report = evaluate_predictions(scored_store, path, measure="VKL")
    assert report.scored_measures == ("VKL",)
    np.testing.assert_array_equal(report.scores[:, 2], expected.scores[:, 2])


def test_npz_with_a_subset_of_measures(scored_store: Path, tmp_path: Path,
                                       reference: tuple[np.ndarray, EvaluationReport]) -> None:
    directions, expected = reference
    path = save_predictions(tmp_path / "sub.npz", TEST_NAMES, directions[:, [1, 3]],
                            measures=["VR", "VMI"])
    report = evaluate_predictions(scored_store, path)
    assert report.scored_measures == ("VR", "VMI")
    np.testing.assert_array_equal(report.scores[:, [1, 3]], expected.scores[:, [1, 3]])
    names, loaded = load_predictions(path, open_dataset(scored_store).split("test"))
    assert np.isnan(loaded[:, [0, 2]]).all() and np.isfinite(loaded[:, [1, 3]]).all()


def test_other_splits_and_an_open_dataset(scored_dataset: ViewpointDataset, tmp_path: Path) -> None:
    for split, label in (("train", "train"), ("val", "val"), (None, "all")):
        subset = scored_dataset if split is None else scored_dataset.split(split)
        path = save_predictions(tmp_path / f"{label}.npz", subset.names,
                                oracle_directions(subset))
        report = evaluate_predictions(scored_dataset, path, split=split)
        assert report.split == label and report.n_models == len(subset)
        np.testing.assert_array_equal(report.mean, 100.0)


def _npz(**arrays: np.ndarray) -> Callable[[Path], Path]:
    def write(folder: Path) -> Path:
        fields = {"names": np.array(TEST_NAMES), "measures": np.array(PAPER_MEASURES),
                  "directions": random_directions(len(TEST_NAMES), seed=1), **arrays}
        path = folder / "bad.npz"
        np.savez(path, **{key: value for key, value in fields.items() if value is not None})
        return path
    return write


def _npy(array: np.ndarray, name: str = "bad.npy") -> Callable[[Path], Path]:
    def write(folder: Path) -> Path:
        path = folder / name
        with path.open("wb") as handle:
            np.save(handle, array, allow_pickle=True)
        return path
    return write


def _raw(content: bytes, name: str) -> Callable[[Path], Path]:
    def write(folder: Path) -> Path:
        (folder / name).write_bytes(content)
        return folder / name
    return write


def _truncated(write: Callable[[Path], Path], n_bytes: int) -> Callable[[Path], Path]:
    def write_truncated(folder: Path) -> Path:
        path = write(folder)
        path.write_bytes(path.read_bytes()[:n_bytes])
        return path
    return write_truncated


def _with(index: tuple[int, ...], value: float, n: int = len(TEST_NAMES)) -> np.ndarray:
    directions = random_directions(n, seed=2)
    directions[index] = value
    return directions


N_TEST = len(TEST_NAMES)
OBJECTS = np.array([np.zeros(3), "x"], dtype=object)
BAD_CASES = {
    "txt-suffix": (_raw(b"1 2 3", "bad.txt"), None, "must be a .npy or .npz file"),
    "missing-file": (lambda folder: folder / "absent.npz", None, "no such file"),
    "corrupt-npz": (_raw(b"not a zip", "bad.npz"), None, "not a numpy .npy or .npz file"),
    "empty-npy": (_raw(b"", "bad.npy"), None, "not a numpy .npy or .npz file"),
    "truncated-npz": (_truncated(_npz(), 200), None, "allow_pickle=False"),
    "truncated-npy": (_truncated(_npy(np.ones((N_TEST, 4, 3))), 140), None, "but the file holds"),
    "object-npy": (_npy(OBJECTS), None, "allow_pickle=False"),
    "object-in-npz": (_npz(names=np.array(TEST_NAMES, dtype=object)), None, "allow_pickle=False"),
    "npz-named-npy": (lambda folder: _npz()(folder).rename(folder / "bad.npy"), None,
                      "not a .npy array"),
    "npy-shape": (_npy(np.ones((N_TEST, 4, 2))), None, "expected shape (n_models, 4, 3)"),
    "npy-1d": (_npy(np.ones(N_TEST)), None, "expected shape"),
    "npy-count": (_npy(random_directions(N_TEST + 1, seed=0)), None, "holds 7 predictions"),
    "npy-nan": (_npy(_with((2, 1, 0), np.nan)), None,
                "'airplane_0005' for VR is NaN or infinite (1 of 24"),
    "npy-inf": (_npy(_with((0, 3, 2), np.inf)), None, "NaN or infinite"),
    "npy-zero": (_npy(_with((5, 0), 0.0)), None, "'table_0002' for VE is a zero vector"),
    "npy-strings": (_npy(np.full((N_TEST, 4, 3), "a")), None, "must be numeric"),
    "n3-without-measure": (_npy(np.ones((N_TEST, 3))), None, "needs the measure"),
    "n3-count": (_npy(np.ones((2, 3))), "VE", "holds 2 predictions"),
    "npz-missing-key": (_npz(measures=None), None, "missing key(s) measures"),
    "npz-names-not-unicode": (_npz(names=np.arange(N_TEST)), None, "1-D unicode"),
    "npz-shape": (_npz(directions=np.ones((N_TEST, 4))), None, "directions must have shape"),
    "npz-nan": (_npz(directions=_with((1, 2, 1), np.nan)), None, "'airplane_0003' for VKL is NaN"),
    "npz-zero": (_npz(directions=_with((3, 3), 0.0)), None, "zero vector"),
    "npz-unknown-name": (_npz(names=np.array(TEST_NAMES[:-1] + ["lamp_0001"])), None,
                         "1 name not in split 'test' of dataset.zarr: 'lamp_0001'"),
    "npz-other-split": (_npz(names=np.array(TEST_NAMES[:-1] + ["chair_0001"])), None,
                        "1 name not in split 'test'"),
    "npz-duplicate-name": (_npz(names=np.array(TEST_NAMES[:-1] + TEST_NAMES[:1])), None,
                           "duplicate names 'airplane_0002'"),
    "npz-count": (_npz(names=np.array(TEST_NAMES[:-1]),
                       directions=random_directions(N_TEST - 1, seed=0)), None,
                  "holds 5 predictions, split 'test' of dataset.zarr has 6 models; "
                  "missing 'table_0002'"),
    "npz-names-directions-count": (_npz(names=np.array(TEST_NAMES[:-1])), None,
                                   "directions must have shape (5, 4, 3)"),
    "npz-duplicate-measure": (_npz(measures=np.array(["VE", "VE", "VKL", "VMI"])), None,
                              "name VE twice"),
    "npz-unknown-measure": (_npz(measures=np.array(["VE", "VR", "VKL", "ENT"])), None,
                            "unknown measure(s) 'ENT'"),
    "npz-measure-not-predicted": (_npz(measures=np.array(["VE"]),
                                       directions=random_directions(N_TEST, seed=0)[:, :1]),
                                  "VMI", "measure 'VMI' is not predicted"),
}


@pytest.mark.parametrize("write, measure, message", list(BAD_CASES.values()), ids=list(BAD_CASES))
def test_bad_predictions_give_one_line_naming_the_file(
        scored_store: Path, tmp_path: Path, write: Callable[[Path], Path], measure: str | None,
        message: str) -> None:
    path = write(tmp_path)
    with pytest.raises(InputError) as caught:
        evaluate_predictions(scored_store, path, measure=measure)
    text = str(caught.value)
    assert "\n" not in text
    assert text.startswith(f"{path.name}: "), text
    assert message in text


@pytest.mark.parametrize("keyword, value, message", [
    ("measure", "ENT", "measure: unknown measure 'ENT'"),
    ("split", "training", "split: unknown split 'training'"),
], ids=["measure", "split"])
def test_bad_options_name_the_argument(scored_store: Path, tmp_path: Path, keyword: str, value: str,
                                       message: str) -> None:
    path = save_predictions(tmp_path / "p.npz", TEST_NAMES, random_directions(N_TEST, seed=0))
    with pytest.raises(InputError, match=message):
        evaluate_predictions(scored_store, path, **{keyword: value})


def test_empty_split_is_an_input_error(tmp_path: Path) -> None:
    entries = [synthetic_entry("chair", "chair_0001", "train")]
    store = write_synthetic(tmp_path / "tiny.zarr", entries)
    path = save_predictions(tmp_path / "p.npz", [], np.zeros((0, 4, 3)))
    with pytest.raises(InputError, match="tiny.zarr: split 'test' has no models"):
        evaluate_predictions(store, path)


def test_score_directions_checks_its_array(test_split: ViewpointDataset) -> None:
    directions = random_directions(N_TEST, seed=0)
    with pytest.raises(InputError, match=r"directions: expected shape \(6, 4, 3\)"):
        score_directions(test_split, directions[:, :3])
    partial = directions.copy()
    partial[0, 1] = np.nan
    with pytest.raises(InputError, match="VR predicted for some models only"):
        score_directions(test_split, partial)
    with pytest.raises(InputError, match="no measure is predicted"):
        score_directions(test_split, np.full_like(directions, np.nan))


def test_evaluation_imports_numpy_only(scored_store: Path, tmp_path: Path) -> None:
    path = save_predictions(tmp_path / "p.npz", TEST_NAMES, random_directions(N_TEST, seed=0))
    code = (
        "import sys; from vptoolkit.evaluate.scores import evaluate_predictions; "
        f"evaluate_predictions({str(scored_store)!r}, {str(path)!r}).format_table(); "
        "print(','.join(m for m in ('torch', 'open3d', 'pymeshlab', 'numba', 'trimesh') "
        "if m in sys.modules))"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.strip()
    assert loaded == ""


def test_to_dict_is_json_safe(test_split: ViewpointDataset) -> None:
    directions = fixed_view_directions(test_split, [7, 0, 23, 49])
    directions[:, 2] = np.nan
    report = score_directions(test_split, directions)
    as_dict = report.to_dict(per_model=True)
    text = json.dumps(as_dict, allow_nan=False)
    assert json.loads(text) == as_dict
    assert as_dict["measures"] == list(PAPER_MEASURES) and as_dict["scored_measures"] == [
        "VE", "VR", "VMI"]
    assert list(as_dict["categories"]) == ["airplane", "chair", "table"]
    assert as_dict["categories"]["airplane"]["n_models"] == 3
    assert as_dict["categories"]["table"]["VKL"] is None
    assert as_dict["mean"]["VE"] == pytest.approx(float(report.mean[0]))
    assert [model["name"] for model in as_dict["models"]] == TEST_NAMES
    assert "models" not in report.to_dict()


def test_format_table_follows_the_paper_layout(test_split: ViewpointDataset) -> None:
    directions = fixed_view_directions(test_split, [7, 0, 23, 49])
    directions[:, 3] = np.nan
    report = score_directions(test_split, directions)
    lines = report.format_table().split("\n")
    assert "split 'test' of dataset.zarr" in lines[0]
    assert lines[1].split() == ["category", "n", *PAPER_MEASURES]
    rows = [line.split() for line in lines[3:6]]
    assert [row[:2] for row in rows] == [["airplane", "3"], ["chair", "1"], ["table", "2"]]
    assert rows[0][2:] == [f"{v:.1f}" for v in report.category_scores[0, :3]] + ["-"]
    assert lines[-1].split() == ["mean", "6", *(f"{v:.1f}" for v in report.mean[:3]), "-"]
    assert set(lines[2]) == set(lines[-2]) == {"-", " "}
    assert len({len(line) for line in lines[1:]}) == 1  # aligned columns

    transposed = report.format_table(transpose=True, digits=2).split("\n")
    assert transposed[1].split() == ["measure", "airplane", "chair", "table", "mean"]
    assert transposed[2].split() == ["n", "3", "1", "2", "6"]
    assert transposed[4].split() == ["VE", *(f"{v:.2f}" for v in report.category_scores[:, 0]),
                                     f"{report.mean[0]:.2f}"]
    assert transposed[-1].split()[1:] == ["-"] * 4


def test_save_predictions_checks_its_input(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="p.npy: predictions must be saved as .npz"):
        save_predictions(tmp_path / "p.npy", TEST_NAMES, np.ones((N_TEST, 4, 3)))
    with pytest.raises(InputError, match="measures: "):
        save_predictions(tmp_path / "p.npz", TEST_NAMES, np.ones((N_TEST, 2, 3)),
                         measures=["VR", "VR"])
    with pytest.raises(InputError, match=r"directions: expected shape \(6, 4, 3\)"):
        save_predictions(tmp_path / "p.npz", TEST_NAMES, np.ones((N_TEST, 3)))


# --- a dataset of other measures ----------------------------------------------------------


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
