"""A store of any registered measures: the writer records their names and directions and
checks the arrays' columns; the reader follows the names and refuses what contradicts them."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from fixtures.stores import BUILD, N_VIEWS, STORE_NAMES, synthetic_entries, write_synthetic
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.dataset.store.schema import ModelEntry
from vptoolkit.errors import InputError, VerificationError

THREE = ("VE", "NVT", "SL")
"""Three measures of the survey, all higher-is-better, in a store's own order."""


def three_column_entries(columns: tuple[int, ...] = (0, 1, 3)) -> list[ModelEntry]:
    """The synthetic models with their measure arrays cut to three columns (of the four)."""
    picked = list(columns)
    return [dataclasses.replace(
        entry, quality=entry.quality[:, picked], quality_raw=entry.quality_raw[:, picked],
        best_index=entry.best_index[picked], best_value=entry.best_value[picked],
        worst_index=entry.worst_index[picked], worst_value=entry.worst_value[picked],
    ) for entry in synthetic_entries()]


@pytest.mark.parametrize("kind", sorted(STORE_NAMES))
def test_a_store_records_its_measures_and_their_directions(kind: str, tmp_path: Path) -> None:
    entries = three_column_entries()
    store = write_synthetic(tmp_path / STORE_NAMES[kind], entries,
                            attrs={**BUILD, "measures": list(THREE)})
    with open_store(store) as reader:
        assert reader.attrs["measures"] == list(THREE)
        assert reader.attrs["higher_is_better"] == [True, True, True]
        assert reader.measures == THREE and reader.higher_is_better == (True, True, True)
        assert reader.array("quality").shape == (len(entries), N_VIEWS, 3)
        for name in ("best_index", "best_value", "worst_index", "worst_value"):
            assert reader.array(name).shape == (len(entries), 3), name
        np.testing.assert_array_equal(reader.entry(1).quality_raw, entries[1].quality_raw
                                      .astype(np.float32))


def test_the_directions_come_from_the_registry_in_the_stores_order(tmp_path: Path) -> None:
    # VKL and VMI are lower-is-better, VR higher: each name keeps its own direction.
    store = write_synthetic(tmp_path / "d.h5", attrs={**BUILD,
                                                      "measures": ["VKL", "VR", "VMI", "VE"]})
    with open_store(store) as reader:
        assert reader.attrs["higher_is_better"] == [False, True, False, True]
        assert reader.higher_is_better == (False, True, False, True)


def test_a_store_without_measures_holds_the_paper_four(tmp_path: Path) -> None:
    with open_store(write_synthetic(tmp_path / "d.zarr")) as reader:
        assert reader.measures == ("VE", "VR", "VKL", "VMI")
        assert reader.attrs["higher_is_better"] == [True, True, False, False]


@pytest.mark.parametrize(("measures", "message"), [
    (["VE", "XYZ", "SL"], "attrs: measures: unknown measure 'XYZ'"),
    (["VE", "SL", "VE"], "attrs: measures: VE named twice"),
    ([], "attrs: measures must be a non-empty list of names"),
    ("VE,NVT,SL", "attrs: measures must be a non-empty list of names"),
])
def test_bad_measure_names_are_refused_in_one_line(measures: object, message: str,
                                                    tmp_path: Path) -> None:
    with pytest.raises(InputError, match=message) as caught:
        write_synthetic(tmp_path / "d.zarr", three_column_entries(),
                        attrs={**BUILD, "measures": measures})
    assert "\n" not in str(caught.value)
    assert not (tmp_path / "d.zarr").exists()


def test_arrays_of_another_number_of_measures_are_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"quality: expected shape \(50, 3\), got \(50, 4\)"):
        write_synthetic(tmp_path / "d.zarr", attrs={**BUILD, "measures": list(THREE)})
    with pytest.raises(InputError, match=r"quality: expected shape \(50, 4\), got \(50, 3\)"):
        write_synthetic(tmp_path / "d.zarr", three_column_entries())


def test_higher_is_better_passed_through_must_be_the_registrys(tmp_path: Path) -> None:
    attrs = {**BUILD, "measures": list(THREE)}
    with open_store(write_synthetic(tmp_path / "a.zarr", three_column_entries(),
                                    attrs=attrs)) as reader:
        again = dict(reader.attrs)  # attributes read back pass through unchanged
        write_synthetic(tmp_path / "b.zarr", reader.entries(), attrs=again)
    with open_store(tmp_path / "b.zarr") as copied:
        assert copied.measures == THREE
    with pytest.raises(InputError, match="'higher_is_better' is set by the writer"):
        write_synthetic(tmp_path / "c.zarr", three_column_entries(),
                        attrs={**attrs, "higher_is_better": [True, False, True]})


def _set_hdf5_measures(store: Path, names: list[str], higher: list[bool] | None = None) -> None:
    import h5py

    with h5py.File(store, "a") as handle:
        handle.attrs["measures"] = np.array(names, dtype=h5py.string_dtype())
        if higher is not None:
            handle.attrs["higher_is_better"] = np.array(higher)


def test_a_measure_axis_that_does_not_match_the_names_is_refused(tmp_path: Path) -> None:
    store = write_synthetic(tmp_path / "d.h5")
    _set_hdf5_measures(store, ["VE", "VR", "VKL"], [True, True, False])
    with pytest.raises(VerificationError,
                       match=r"d.h5: array 'quality' of shape \(5, 50, 4\) does not hold one "
                             r"column per measure of \['VE', 'VR', 'VKL'\]"):
        open_store(store)


@pytest.mark.parametrize(("names", "higher", "message"), [
    (["VE", "VR", "VE", "VMI"], None, "is not a list of distinct names"),
    (["VE", "VR", "VKL", "VMI"], [True, True, False], "does not give one direction per measure"),
])
def test_malformed_measure_attributes_are_refused(names: list[str], higher: list[bool] | None,
                                                  message: str, tmp_path: Path) -> None:
    store = write_synthetic(tmp_path / "d.h5")
    _set_hdf5_measures(store, names, higher)
    with pytest.raises(VerificationError, match=message):
        open_store(store)


def test_a_measure_the_registry_does_not_know_loads_but_has_no_direction(tmp_path: Path) -> None:
    store = write_synthetic(tmp_path / "d.h5", three_column_entries(),
                            attrs={**BUILD, "measures": list(THREE)})
    _set_hdf5_measures(store, ["VE", "NVT", "FUTURE"])  # as a later version might write
    with open_store(store) as reader:
        assert reader.measures == ("VE", "NVT", "FUTURE")
        assert reader.array("quality").shape[-1] == 3
        with pytest.raises(InputError, match="d.h5: measure 'FUTURE' is not one this vptoolkit "
                                             "knows, so which way it is better is unknown"):
            reader.higher_is_better
