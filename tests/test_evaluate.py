"""Nearest-sample scoring of predicted viewpoints, prediction files and baselines."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from fixtures.stores import synthetic_entry, write_synthetic
from vptoolkit.conventions import MEASURES
from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.errors import InputError
from vptoolkit.evaluate.baselines import oracle_directions, pca_directions, random_directions
from vptoolkit.evaluate.scores import (
    EvaluationReport,
    evaluate_predictions,
    load_predictions,
    score_directions,
)
from vptoolkit.predictions import write_predictions as save_predictions

# (category, name, split) in (category, name) order; uneven categories in the test
# split (airplane 3, chair 1, table 2) so the mean over categories differs from
# the mean over models.
MODELS = [
    ("airplane", "airplane_0001", "train"),
    ("airplane", "airplane_0002", "test"),
    ("airplane", "airplane_0003", "test"),
    ("airplane", "airplane_0004", "val"),
    ("airplane", "airplane_0005", "test"),
    ("airplane", "airplane_0006", "train"),
    ("chair", "chair_0001", "train"),
    ("chair", "chair_0002", "test"),
    ("chair", "chair_0003", "train"),
    ("table", "table_0001", "test"),
    ("table", "table_0002", "test"),
]
TEST_NAMES = [name for _, name, split in MODELS if split == "test"]
ENTRIES = [synthetic_entry(category, name, split) for category, name, split in MODELS]
QUALITY = {entry.name: np.asarray(entry.quality, np.float32) for entry in ENTRIES}


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_synthetic(tmp_path_factory.mktemp("evaluate") / "dataset.zarr", ENTRIES)


@pytest.fixture(scope="module")
def dataset(store: Path) -> Iterator[ViewpointDataset]:
    with open_dataset(store) as opened:
        yield opened


@pytest.fixture(scope="module")
def test_split(dataset: ViewpointDataset) -> ViewpointDataset:
    return dataset.split("test")


def fixed_view_directions(split: ViewpointDataset, view_of_measure: list[int]) -> np.ndarray:
    """Directions pointing at given sampled views (scaled, so not unit length)."""
    return np.stack([3.0 * split.views[view_of_measure]] * len(split))


# --------------------------------------------------------------------------- scoring


def test_oracle_scores_100_percent(store: Path, test_split: ViewpointDataset,
                                   tmp_path: Path) -> None:
    oracle = oracle_directions(test_split)
    assert oracle.shape == (len(TEST_NAMES), 4, 3) and oracle.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(oracle, axis=2), 1.0)
    path = save_predictions(tmp_path / "oracle.npz", test_split.names, oracle)
    report = evaluate_predictions(store, path)
    assert (report.split, report.dataset, report.predictions) == ("test", "dataset.zarr",
                                                                  "oracle.npz")
    assert report.names == tuple(TEST_NAMES)
    np.testing.assert_array_equal(report.scores, 100.0)
    np.testing.assert_array_equal(report.category_scores, 100.0)
    np.testing.assert_array_equal(report.mean, 100.0)
    assert report.scored_measures == MEASURES


def test_random_directions_score_the_mean_quality(dataset: ViewpointDataset) -> None:
    n_seeds = 50
    scores = np.stack([score_directions(dataset, random_directions(len(dataset), seed=seed)).scores
                       for seed in range(n_seeds)])  # (seeds, models, 4)
    view_means = np.stack([QUALITY[name].mean(axis=0) for name in dataset.names])  # (models, 4)
    spread = np.mean([QUALITY[name].std(axis=0) for name in dataset.names])
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
    assert report.is_scored.shape == (4,) and report.measures == MEASURES


# --------------------------------------------------------------------------- file forms


@pytest.fixture(scope="module")
def reference(test_split: ViewpointDataset) -> tuple[np.ndarray, EvaluationReport]:
    directions = random_directions(len(test_split), seed=7) * 2.5
    return directions, score_directions(test_split, directions, split="test")


def test_npy_with_four_measures_matches_npz(store: Path, tmp_path: Path,
                                            reference: tuple[np.ndarray, EvaluationReport]
                                            ) -> None:
    directions, expected = reference
    np.save(tmp_path / "predictions.npy", directions.astype(np.float32))
    report = evaluate_predictions(store, tmp_path / "predictions.npy")
    np.testing.assert_allclose(report.scores, expected.scores)
    assert report.predictions == "predictions.npy"


def test_npz_is_matched_by_name(store: Path, tmp_path: Path,
                                reference: tuple[np.ndarray, EvaluationReport]) -> None:
    directions, expected = reference
    order = np.random.default_rng(3).permutation(len(TEST_NAMES))
    assert (order != np.arange(len(order))).any()
    path = save_predictions(tmp_path / "shuffled.npz", [TEST_NAMES[i] for i in order],
                            directions[order])
    report = evaluate_predictions(store, path)
    assert report.names == tuple(TEST_NAMES)
    np.testing.assert_array_equal(report.scores, expected.scores)
    names, loaded = load_predictions(path, open_dataset(store).split("test"))
    assert names == TEST_NAMES
    np.testing.assert_array_equal(loaded, directions)


@pytest.mark.parametrize("measure", MEASURES)
def test_npy_single_measure(store: Path, tmp_path: Path, measure: str,
                            reference: tuple[np.ndarray, EvaluationReport]) -> None:
    directions, expected = reference
    column = MEASURES.index(measure)
    np.save(tmp_path / "one.npy", directions[:, column])
    report = evaluate_predictions(store, tmp_path / "one.npy", measure=measure.lower())
    assert report.scored_measures == (measure,)
    np.testing.assert_array_equal(report.scores[:, column], expected.scores[:, column])
    assert np.isnan(np.delete(report.scores, column, axis=1)).all()
    assert report.to_dict()["mean"] == {
        m: (float(expected.mean[column]) if m == measure else None) for m in MEASURES}


def test_measure_restricts_a_full_prediction(store: Path, tmp_path: Path,
                                             reference: tuple[np.ndarray, EvaluationReport]
                                             ) -> None:
    directions, expected = reference
    path = save_predictions(tmp_path / "all.npz", TEST_NAMES, directions)
    report = evaluate_predictions(store, path, measure="VKL")
    assert report.scored_measures == ("VKL",)
    np.testing.assert_array_equal(report.scores[:, 2], expected.scores[:, 2])


def test_npz_with_a_subset_of_measures(store: Path, tmp_path: Path,
                                       reference: tuple[np.ndarray, EvaluationReport]) -> None:
    directions, expected = reference
    path = save_predictions(tmp_path / "sub.npz", TEST_NAMES, directions[:, [1, 3]],
                            measures=["VR", "VMI"])
    report = evaluate_predictions(store, path)
    assert report.scored_measures == ("VR", "VMI")
    np.testing.assert_array_equal(report.scores[:, [1, 3]], expected.scores[:, [1, 3]])
    names, loaded = load_predictions(path, open_dataset(store).split("test"))
    assert np.isnan(loaded[:, [0, 2]]).all() and np.isfinite(loaded[:, [1, 3]]).all()


def test_other_splits_and_an_open_dataset(dataset: ViewpointDataset, tmp_path: Path) -> None:
    for split in ("train", "val", "all"):
        subset = dataset if split == "all" else dataset.split(split)
        path = save_predictions(tmp_path / f"{split}.npz", subset.names,
                                oracle_directions(subset))
        report = evaluate_predictions(dataset, path, split=split)
        assert report.split == split and report.n_models == len(subset)
        np.testing.assert_array_equal(report.mean, 100.0)


# --------------------------------------------------------------------------- bad input


def _npz(**arrays: np.ndarray) -> Callable[[Path], Path]:
    def write(folder: Path) -> Path:
        fields = {"names": np.array(TEST_NAMES), "measures": np.array(MEASURES),
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
    "npz-measure-order": (_npz(measures=np.array(["VR", "VE", "VKL", "VMI"])), None,
                          "differ from the order VE, VR, VKL, VMI"),
    "npz-duplicate-measure": (_npz(measures=np.array(["VE", "VE", "VKL", "VMI"])), None,
                              "differ from the order"),
    "npz-unknown-measure": (_npz(measures=np.array(["VE", "VR", "VKL", "ENT"])), None,
                            "unknown measure(s) 'ENT'"),
    "npz-measure-not-predicted": (_npz(measures=np.array(["VE"]),
                                       directions=random_directions(N_TEST, seed=0)[:, :1]),
                                  "VMI", "measure 'VMI' is not predicted"),
}


@pytest.mark.parametrize("write, measure, message", list(BAD_CASES.values()), ids=list(BAD_CASES))
def test_bad_predictions_give_one_line_naming_the_file(
        store: Path, tmp_path: Path, write: Callable[[Path], Path], measure: str | None,
        message: str) -> None:
    path = write(tmp_path)
    with pytest.raises(InputError) as caught:
        evaluate_predictions(store, path, measure=measure)
    text = str(caught.value)
    assert "\n" not in text
    assert text.startswith(f"{path.name}: "), text
    assert message in text


@pytest.mark.parametrize("keyword, value, message", [
    ("measure", "ENT", "measure: unknown measure 'ENT'"),
    ("split", "training", "split: unknown split 'training'"),
], ids=["measure", "split"])
def test_bad_options_name_the_argument(store: Path, tmp_path: Path, keyword: str, value: str,
                                       message: str) -> None:
    path = save_predictions(tmp_path / "p.npz", TEST_NAMES, random_directions(N_TEST, seed=0))
    with pytest.raises(InputError, match=message):
        evaluate_predictions(store, path, **{keyword: value})


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


def test_evaluation_imports_numpy_only(store: Path, tmp_path: Path) -> None:
    path = save_predictions(tmp_path / "p.npz", TEST_NAMES, random_directions(N_TEST, seed=0))
    code = (
        "import sys; from vptoolkit.evaluate.scores import evaluate_predictions; "
        f"evaluate_predictions({str(store)!r}, {str(path)!r}).format_table(); "
        "print(','.join(m for m in ('torch', 'open3d', 'pymeshlab', 'numba', 'trimesh') "
        "if m in sys.modules))"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.strip()
    assert loaded == ""


# --------------------------------------------------------------------------- output


def test_to_dict_is_json_safe(test_split: ViewpointDataset) -> None:
    directions = fixed_view_directions(test_split, [7, 0, 23, 49])
    directions[:, 2] = np.nan
    report = score_directions(test_split, directions)
    as_dict = report.to_dict(per_model=True)
    text = json.dumps(as_dict, allow_nan=False)
    assert json.loads(text) == as_dict
    assert as_dict["measures"] == list(MEASURES) and as_dict["scored_measures"] == [
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
    assert lines[1].split() == ["category", "n", *MEASURES]
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


# --------------------------------------------------------------------------- baselines


def test_random_directions() -> None:
    directions = random_directions(2000, seed=5)
    assert directions.shape == (2000, 4, 3) and directions.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(directions, axis=2), 1.0)
    np.testing.assert_array_equal(directions, random_directions(2000, seed=5))
    assert not np.allclose(directions, random_directions(2000, seed=6))
    # uniform on the sphere: mean ~ 0, each coordinate's second moment ~ 1/3
    flat = directions.reshape(-1, 3)
    np.testing.assert_allclose(flat.mean(axis=0), 0.0, atol=4 / math.sqrt(3 * len(flat)))
    np.testing.assert_allclose((flat**2).mean(axis=0), 1 / 3, atol=0.02)
    assert random_directions(0, seed=0).shape == (0, 4, 3)
    with pytest.raises(InputError, match="n: "):
        random_directions(-1, seed=0)
    with pytest.raises(InputError, match="seed: "):
        random_directions(3, seed=None)  # type: ignore[arg-type]


def _rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _table_cloud(seed: int) -> np.ndarray:
    """A 4 x 2 table top at z = 0.5 with four legs down to z = -0.5 (axes 4 > 2 > 1)."""
    rng = np.random.default_rng(seed)
    top = np.column_stack([rng.uniform(-2, 2, 3000), rng.uniform(-1, 1, 3000), np.full(3000, 0.5)])
    legs = np.concatenate([
        np.column_stack([np.full(150, x), np.full(150, y), rng.uniform(-0.5, 0.5, 150)])
        for x in (-1.9, 1.9) for y in (-0.9, 0.9)
    ])
    return np.concatenate([top, legs])


def test_pca_views_a_table_from_the_top_and_rotates_with_it() -> None:
    table = _table_cloud(0)
    direction = pca_directions(table[None])[0]
    assert direction.shape == (4, 3)
    np.testing.assert_allclose(direction, np.tile([0.0, 0.0, 1.0], (4, 1)), atol=0.01)
    rotations = [_rotation(seed) for seed in range(3)]
    rotated = pca_directions([table @ rotation.T for rotation in rotations])
    for rotation, predicted in zip(rotations, rotated):
        np.testing.assert_allclose(predicted[0], rotation @ direction[0], atol=1e-9)


def test_pca_is_deterministic_and_unit(dataset: ViewpointDataset) -> None:
    clouds = [dataset[i]["points"] for i in range(len(dataset))]
    directions = pca_directions(clouds)
    assert directions.shape == (len(dataset), 4, 3) and directions.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(directions, axis=2), 1.0)
    np.testing.assert_array_equal(directions, pca_directions(np.stack(clouds)))
    np.testing.assert_array_equal(directions, directions[:, :1].repeat(4, axis=1))
    # a symmetric cloud uses the fallback: largest component positive
    box = np.array([[x, y, z] for x in (-2, 2) for y in (-1, 1) for z in (-0.5, 0.5)], float)
    np.testing.assert_allclose(pca_directions([box @ _rotation(4).T])[0, 0],
                               np.sign(_rotation(4)[np.argmax(abs(_rotation(4)[:, 2])), 2])
                               * _rotation(4)[:, 2], atol=1e-9)
    report = score_directions(dataset, directions)
    assert np.isfinite(report.scores).all()


@pytest.mark.parametrize("points, message", [
    (np.ones((2, 10, 2)), "expected (n_models, n_points, 3)"),
    (np.ones((10, 3)), "expected (n_models, n_points, 3)"),
    ([np.ones((10, 3))], "points[0]: all points coincide"),
    ([_table_cloud(0), np.ones((2, 3))], "points[1]: needs at least 3 points"),
    ([np.full((5, 3), np.nan)], "points[0]: contains NaN"),
    ([np.ones((5, 4))], "points[0]: expected shape (n_points, 3)"),
], ids=["last-axis", "single-cloud", "coincident", "too-few", "nan", "list-shape"])
def test_pca_rejects_bad_clouds(points: object, message: str) -> None:
    with pytest.raises(InputError) as caught:
        pca_directions(points)  # type: ignore[arg-type]
    assert message in str(caught.value)


def test_oracle_directions_are_the_stored_best_views(dataset: ViewpointDataset) -> None:
    oracle = oracle_directions(dataset)
    for entry, row in zip(ENTRIES, oracle):
        np.testing.assert_array_equal(row, dataset.views[entry.best_index])


def test_save_predictions_checks_its_input(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="p.npy: predictions must be saved as .npz"):
        save_predictions(tmp_path / "p.npy", TEST_NAMES, np.ones((N_TEST, 4, 3)))
    with pytest.raises(InputError, match="measures: "):
        save_predictions(tmp_path / "p.npz", TEST_NAMES, np.ones((N_TEST, 2, 3)),
                         measures=["VR", "VE"])
    with pytest.raises(InputError, match=r"directions: expected shape \(6, 4, 3\)"):
        save_predictions(tmp_path / "p.npz", TEST_NAMES, np.ones((N_TEST, 3)))
