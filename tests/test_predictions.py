"""The predictions .npz: written atomically, read back without pickles, file closed; the
measures it names, any registered ones, checked by name."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np
import pytest

from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.predictions import (
    PREDICTION_KEYS,
    Predictions,
    check_prediction_measures,
    read_arrays,
    read_predictions,
    write_predictions,
)


def test_round_trip_keeps_names_directions_and_measures(tmp_path):
    directions = np.arange(2 * 4 * 3, dtype=np.float32).reshape(2, 4, 3) + 1.0
    path = write_predictions(tmp_path / "p.npz", ["chair_1", "desk_2"], directions)
    assert not [p.name for p in tmp_path.iterdir() if p.name != "p.npz"]  # no partial left
    with zipfile.ZipFile(path) as archive:
        assert sorted(archive.namelist()) == sorted(f"{key}.npy" for key in PREDICTION_KEYS)
    names, read, measures = read_predictions(path)
    assert names == ("chair_1", "desk_2")
    assert measures == PAPER_MEASURES
    assert read.dtype == np.float64 and read.shape == (2, 4, 3)
    np.testing.assert_array_equal(read, directions)


def test_a_subset_of_measures_in_order(tmp_path):
    path = write_predictions(tmp_path / "p.npz", ["a"], np.ones((1, 2, 3)), measures=("VE", "VMI"))
    assert read_predictions(path).measures == ("VE", "VMI")


def open_files() -> set[str]:
    """Paths this process holds open (Linux /proc)."""
    folder = Path("/proc/self/fd")
    held = set()
    for fd in folder.iterdir():
        try:
            held.add(os.readlink(fd))
        except OSError:
            continue
    return held


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs Linux /proc")
def test_the_file_is_closed_after_reading(tmp_path):
    path = write_predictions(tmp_path / "p.npz", ["a"], np.ones((1, 4, 3)))
    read_predictions(path)
    assert str(path) not in open_files()


@pytest.mark.parametrize(
    ("arrays", "message"),
    [
        pytest.param({"names": np.array(["a"])}, "missing key(s) directions, measures",
                     id="missing-keys"),
        pytest.param({"names": np.array(["a"]), "directions": np.ones((1, 1, 3)),
                      "measures": np.array(["VX"])}, "unknown measure(s) 'VX'",
                     id="unknown-measure"),
        pytest.param({"names": np.array(["a"]), "directions": np.ones((2, 4, 3)),
                      "measures": np.array(PAPER_MEASURES)}, "directions must have shape (1, 4, 3)",
                     id="shape"),
        pytest.param({"names": np.array([1]), "directions": np.ones((1, 4, 3)),
                      "measures": np.array(PAPER_MEASURES)}, "'names' must be a 1-D unicode array",
                     id="names-not-unicode"),
    ],
)
def test_bad_archives_name_the_file_and_the_problem(tmp_path, arrays, message):
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    with pytest.raises(InputError, match="^bad.npz: ") as caught:
        read_predictions(path)
    assert message in str(caught.value)


def test_an_object_array_is_refused_not_unpickled(tmp_path):
    path = tmp_path / "p.npz"
    np.savez(path, names=np.array([{"x": 1}], dtype=object), directions=np.ones((1, 4, 3)),
             measures=np.array(PAPER_MEASURES))
    with pytest.raises(InputError, match="allow_pickle=False"):
        read_arrays(path)


def test_a_npy_is_not_a_predictions_archive(tmp_path):
    path = tmp_path / "p.npy"
    np.save(path, np.ones((1, 4, 3)))
    with pytest.raises(InputError, match="p.npy: predictions must be a .npz file"):
        read_predictions(path)


def test_write_refuses_duplicate_names(tmp_path):
    with pytest.raises(InputError, match="names: model names must be unique"):
        write_predictions(tmp_path / "p.npz", ["a", "a"], np.ones((2, 4, 3)))


# --- predictions of any registered measures -----------------------------------------------


THREE = ("SL", "NVT", "MD")
"""Three measures outside the paper's four, in an order that is not the registry's."""


def test_three_other_measures_round_trip_in_their_order(tmp_path):
    directions = np.random.default_rng(0).normal(size=(2, 3, 3))
    path = Predictions(("chair_1", "desk_2"), directions, THREE).save_npz(tmp_path / "p.npz")
    names, read, measures = read_predictions(path)
    assert names == ("chair_1", "desk_2") and measures == THREE
    assert read.shape == (2, 3, 3) and read.dtype == np.float64
    np.testing.assert_array_equal(read, directions)
    with np.load(path, allow_pickle=False) as archive:
        assert archive["measures"].tolist() == list(THREE)


def test_other_measures_mix_with_the_paper_four_kept_in_order(tmp_path):
    measures = ("NVT", "VE", "SL", "VMI", "I3")
    path = write_predictions(tmp_path / "p.npz", ["a"], np.ones((1, 5, 3)), measures=measures)
    assert read_predictions(path).measures == measures
    assert check_prediction_measures(PAPER_MEASURES) == PAPER_MEASURES
    assert check_prediction_measures(["VMI"]) == ("VMI",)
    # any order: the registry's "all" lists VR before VE
    assert check_prediction_measures(["NVT", "VKL", "VE"]) == ("NVT", "VKL", "VE")


@pytest.mark.parametrize(("measures", "message"), [
    (("NVT", "XX"), "unknown measure(s) 'XX'"),
    (("SL", "NVT", "SL"), "name SL twice"),
    ((), "no measure named"),
], ids=["unknown", "repeated", "none"])
def test_bad_measure_names_are_one_line(tmp_path, measures, message):
    directions = np.ones((1, len(measures), 3))
    with pytest.raises(InputError) as written:
        write_predictions(tmp_path / "p.npz", ["a"], directions, measures=measures)
    with pytest.raises(InputError) as made:
        Predictions(("a",), directions, measures)
    path = tmp_path / "bad.npz"
    np.savez(path, names=np.array(["a"]), directions=directions,
             measures=np.array(measures, dtype=str))
    with pytest.raises(InputError) as read:
        read_predictions(path)
    for caught in (written, made, read):
        assert message in str(caught.value) and "\n" not in str(caught.value)
    assert str(read.value).startswith("bad.npz: ")
    assert not (tmp_path / "p.npz").exists()


def test_the_shape_follows_the_number_of_measures():
    with pytest.raises(InputError, match=r"expected shape \(1, 3, 3\)"):
        Predictions(("a",), np.ones((1, 4, 3)), THREE)
