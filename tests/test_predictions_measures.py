"""Predictions of any registered measures: written, read back, and checked by name."""

from __future__ import annotations

import numpy as np
import pytest

from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.predictions import (
    Predictions,
    check_prediction_measures,
    read_predictions,
    write_predictions,
)

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
