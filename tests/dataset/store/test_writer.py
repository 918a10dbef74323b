"""write_dataset: the SCHEMA.md layout in Zarr (directory, zip) and HDF5, read back
unchanged; two checked passes; atomic replacement; a store of any registered measures,
whose names the reader follows."""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import weakref
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fixtures.releases import write_build_to_pack
from fixtures.stores import (
    BUILD,
    FAILURES,
    MODELS,
    N_POINTS,
    N_VIEWS,
    STORE_NAMES,
    synthetic_entries,
    synthetic_entry,
    write_synthetic,
)
from vptoolkit.dataset.store.containers import store_kind
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.dataset.store.schema import (
    ARRAY_NAMES,
    BUILD_ATTRS,
    FORMAT_NAME,
    SCHEMA_VERSION,
    STRING_ARRAYS,
    ModelEntry,
    array_sha256,
    string_values,
)
from vptoolkit.dataset.store.writer import write_dataset
from vptoolkit.errors import InputError, VerificationError
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.sphere import fibonacci_sphere

KINDS = list(STORE_NAMES)


class LazyEntries(Sequence[ModelEntry]):
    """Entries made on demand; counts reads, tracks how many are alive, can fail."""

    def __init__(self, entries: list[ModelEntry], *,
                 fail: Callable[[int, int], bool] = lambda index, read: False) -> None:
        self._entries = entries
        self._fail = fail
        self.reads = [0] * len(entries)
        self.max_alive = 0
        self._alive: list[weakref.ref[ModelEntry]] = []

    def __len__(self) -> int:
        return len(self._entries)

    def __getitem__(self, index: int) -> ModelEntry:  # type: ignore[override]
        self.reads[index] += 1
        if self._fail(index, self.reads[index]):
            raise OSError(f"simulated failure reading entry {index}")
        source = self._entries[index]
        entry = ModelEntry(**{k: getattr(source, k) for k in source.__dataclass_fields__})
        self._alive = [ref for ref in self._alive if ref() is not None] + [weakref.ref(entry)]
        self.max_alive = max(self.max_alive, len(self._alive))
        return entry


def expected_dtype(name: str) -> np.dtype[Any]:
    return np.dtype({
        "views": "<f8", "best_index": "<i8", "worst_index": "<i8", "mesh_vertex_offsets": "<i8",
        "mesh_face_offsets": "<i8", "mesh_faces": "<i4", "models_json": "u1", "failures_json": "u1",
        "labels": "<i8",
    }.get(name, "<f4"))


@pytest.mark.parametrize("kind", KINDS)
def test_round_trip_gives_identical_entries(stores: dict[str, Path], kind: str) -> None:
    entries = synthetic_entries()
    with open_store(stores[kind]) as reader:
        assert reader.kind == kind and store_kind(reader.path) == kind
        assert reader.models() == [entry.record() for entry in entries]
        assert reader.failures() == FAILURES
        for index, entry in enumerate(entries):
            stored = reader.entry(index)
            assert stored.record() == entry.record()
            for field, dtype in [("points", np.float32), ("normals", np.float32),
                                 ("quality", np.float32), ("quality_raw", np.float32),
                                 ("best_index", np.int64), ("best_value", np.float32),
                                 ("worst_index", np.int64), ("worst_value", np.float32),
                                 ("vertices", np.float32), ("faces", np.int32)]:
                value = getattr(stored, field)
                assert value.dtype == dtype, field
                np.testing.assert_array_equal(value, getattr(entry, field).astype(dtype), field)
        assert reader.entry(-1).name == entries[-1].name
        with pytest.raises(IndexError):
            reader.entry(len(entries))


@pytest.mark.parametrize("kind", KINDS)
def test_root_attributes_follow_the_schema(stores: dict[str, Path], kind: str) -> None:
    with open_store(stores[kind]) as reader:
        attrs = reader.attrs
    assert attrs["format"] == FORMAT_NAME and attrs["schema_version"] == SCHEMA_VERSION
    assert attrs["measures"] == list(PAPER_MEASURES)
    assert attrs["higher_is_better"] == [True, True, False, False]
    assert (attrs["n_models"], attrs["n_views"], attrs["n_points"]) == (5, N_VIEWS, N_POINTS)
    assert attrs["n_failures"] == 1
    assert {key: attrs[key] for key in BUILD_ATTRS} == BUILD
    assert "json_attributes" not in attrs
    assert json.loads(json.dumps(attrs)) == attrs  # JSON types only


@pytest.mark.parametrize("kind", KINDS)
def test_arrays_have_schema_shapes_dtypes_and_checksums(stores: dict[str, Path], kind: str) -> None:
    n_models = len(MODELS)
    entries = synthetic_entries()
    n_vertices = sum(len(entry.vertices) for entry in entries)
    n_faces = sum(len(entry.faces) for entry in entries)
    shapes = {
        "views": (N_VIEWS, 3),
        "points": (n_models, N_POINTS, 3), "normals": (n_models, N_POINTS, 3),
        "quality": (n_models, N_VIEWS, 4), "quality_raw": (n_models, N_VIEWS, 4),
        "best_index": (n_models, 4), "best_value": (n_models, 4), "worst_index": (n_models, 4),
        "worst_value": (n_models, 4), "mesh_vertices": (n_vertices, 3),
        "mesh_vertex_offsets": (n_models + 1,), "mesh_faces": (n_faces, 3),
        "mesh_face_offsets": (n_models + 1,),
    }
    with open_store(stores[kind]) as reader:
        assert reader.array_names() == sorted(ARRAY_NAMES)
        for name in ARRAY_NAMES:
            array = reader.array(name)
            if name in STRING_ARRAYS:
                assert np.dtype(array.dtype).kind in "OT", name  # h5py's and zarr's strings
            else:
                assert np.dtype(array.dtype) == expected_dtype(name), name
            if name in shapes:
                assert tuple(array.shape) == shapes[name], name
            content = np.asarray(array[...])
            assert reader.stored_sha256(name) == array_sha256(content), name
            assert array_sha256(array) == array_sha256(content), name  # streamed digest
        np.testing.assert_array_equal(reader.array("views")[...], fibonacci_sphere(N_VIEWS))
        offsets = reader.array("mesh_vertex_offsets")[...]
        assert offsets[0] == 0 and offsets[-1] == n_vertices
        with pytest.raises(InputError, match="no array 'nope'"):
            reader.array("nope")


def test_the_three_formats_hold_identical_arrays(stores: dict[str, Path]) -> None:
    with open_store(stores["zarr"]) as reference:
        for kind in ("zarr-zip", "hdf5"):
            with open_store(stores[kind]) as other:
                assert other.attrs == reference.attrs
                for name in ARRAY_NAMES:
                    a, b = reference.array(name)[...], other.array(name)[...]
                    if name in STRING_ARRAYS:
                        assert string_values(a) == string_values(b), (kind, name)
                        continue
                    assert a.dtype == b.dtype and a.shape == b.shape, (kind, name)
                    assert a.tobytes() == b.tobytes(), (kind, name)
                    assert other.stored_sha256(name) == reference.stored_sha256(name)


def test_chunks_follow_the_schema(stores: dict[str, Path]) -> None:
    import h5py
    import zarr

    group = zarr.open_group(stores["zarr"], mode="r")
    assert group["points"].chunks == (1, N_POINTS, 3)
    assert group["quality"].chunks == (64, N_VIEWS, 4)
    assert group["best_index"].chunks == (64, 4)
    with h5py.File(stores["hdf5"], "r") as handle:
        assert handle["points"].chunks == (1, N_POINTS, 3)
        assert handle["quality"].chunks == (len(MODELS), N_VIEWS, 4)  # 64 models, clipped
        assert handle["points"].compression == "gzip" and handle["points"].shuffle


def test_zip_has_each_member_once(stores: dict[str, Path]) -> None:
    names = zipfile.ZipFile(stores["zarr-zip"]).namelist()
    assert len(names) == len(set(names))
    assert "zarr.json" in names and "points/zarr.json" in names


def test_hdf5_keeps_scalars_and_lists_native_and_objects_as_json(stores: dict[str, Path]) -> None:
    import h5py

    with h5py.File(stores["hdf5"], "r") as handle:
        assert int(handle.attrs["n_models"]) == len(MODELS)
        assert handle.attrs["backend"] == "raster"
        assert json.loads(handle.attrs["camera"]) == BUILD["camera"]
        assert handle.attrs["measures"].tolist() == list(PAPER_MEASURES)
        assert handle.attrs["higher_is_better"].tolist() == [True, True, False, False]
        assert handle.attrs["class_names"].tolist() == ["airplane", "chair"]
        assert set(json.loads(handle.attrs["json_attributes"])) == {
            "camera", "cleaning", "split_fractions"}


def test_names_categories_splits_and_labels_read_with_h5py_or_zarr_alone(
        stores: dict[str, Path]) -> None:
    import h5py
    import zarr

    names = [name for _, name, _ in MODELS]
    categories = [category for category, _, _ in MODELS]
    splits = [{"val": "validation"}.get(split, split) for _, _, split in MODELS]
    labels = [0, 0, 0, 1, 1]
    group = zarr.open_group(stores["zarr"], mode="r")
    assert group.attrs["class_names"] == ["airplane", "chair"]
    assert group["names"][...].tolist() == names
    assert group["categories"][...].tolist() == categories
    assert group["splits"][...].tolist() == splits
    assert group["labels"][...].tolist() == labels
    with h5py.File(stores["hdf5"], "r") as handle:
        assert handle["names"].asstr()[...].tolist() == names
        assert handle["categories"].asstr()[...].tolist() == categories
        assert handle["splits"].asstr()[...].tolist() == splits
        assert handle["labels"][...].tolist() == labels


def test_class_names_are_kept_when_given_and_checked(tmp_path: Path) -> None:
    kept = write_synthetic(tmp_path / "kept.h5",
                           attrs={**BUILD, "class_names": ["airplane", "bench", "chair"]})
    with open_store(kept) as reader:
        assert reader.attrs["class_names"] == ["airplane", "bench", "chair"]
        assert reader.array("labels")[...].tolist() == [0, 0, 0, 2, 2]
    with pytest.raises(InputError, match="class_names: category 'chair' has no label"):
        write_synthetic(tmp_path / "bad.h5", attrs={**BUILD, "class_names": ["airplane"]})
    with pytest.raises(InputError, match="sorted, unique"):
        write_synthetic(tmp_path / "bad.h5", attrs={**BUILD, "class_names": ["chair", "airplane"]})


def test_a_store_converts_to_another_format_unchanged(stores: dict[str, Path],
                                                      tmp_path: Path) -> None:
    with open_store(stores["zarr"]) as reader:
        entries = [reader.entry(index) for index in range(reader.n_models)]
        target = write_dataset(tmp_path / "release.h5", entries, attrs=reader.attrs,
                               views=reader.array("views")[...], failures=reader.failures())
        with open_store(target) as converted:
            assert converted.attrs == reader.attrs
            for name in ARRAY_NAMES:
                assert converted.stored_sha256(name) == reader.stored_sha256(name), name


def test_entries_are_read_twice_and_not_held(tmp_path: Path) -> None:
    models = [("cat", f"m_{index:03d}", "train") for index in range(12)]
    lazy = LazyEntries(synthetic_entries(models))
    write_synthetic(tmp_path / "d.zarr.zip", lazy)
    assert lazy.reads == [2] * len(models)
    assert lazy.max_alive <= 2


def _listing(folder: Path) -> list[str]:
    return sorted(path.name for path in folder.iterdir())


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("read", [1, 2], ids=["first-pass", "while-writing"])
def test_failed_write_leaves_no_target_and_no_leftovers(tmp_path: Path, kind: str,
                                                        read: int) -> None:
    lazy = LazyEntries(synthetic_entries(), fail=lambda index, n: index == 3 and n == read)
    with pytest.raises(OSError, match="simulated failure"):
        write_synthetic(tmp_path / STORE_NAMES[kind], lazy)
    assert _listing(tmp_path) == []


def test_a_full_disk_waits_for_writes_in_flight_then_cleans_up(tmp_path: Path, monkeypatch,
                                                                 caplog) -> None:
    """One chunk write fails while others still run: they finish first, then nothing is left."""
    import errno
    import gc
    import time

    local = pytest.importorskip("zarr.storage._local")

    real = local._put
    calls = {"n": 0}

    def put(path, value, exclusive=False):
        calls["n"] += 1
        if calls["n"] == 30:
            raise OSError(errno.ENOSPC, "No space left on device")
        if calls["n"] > 30:
            time.sleep(0.3)  # a write still in flight when the first one failed
        return real(path, value, exclusive=exclusive)

    monkeypatch.setattr(local, "_put", put)
    entries = [synthetic_entry("chair", f"chair_{i:04d}", "train") for i in range(40)]
    target = tmp_path / "x.zarr"
    with caplog.at_level(logging.ERROR, logger="asyncio"):
        with pytest.raises(OSError) as caught:
            write_synthetic(target, entries)
        time.sleep(0.5)
        gc.collect()
    assert caught.value.filename == str(target)
    assert "No space left on device" in str(caught.value)
    assert _listing(tmp_path) == []
    assert "never retrieved" not in caplog.text


@pytest.mark.parametrize("kind", KINDS)
def test_failed_write_keeps_the_previous_store(tmp_path: Path, kind: str) -> None:
    target = write_synthetic(tmp_path / STORE_NAMES[kind], synthetic_entries(MODELS[:2]))
    lazy = LazyEntries(synthetic_entries(), fail=lambda index, n: index == 4 and n == 2)
    with pytest.raises(OSError, match="simulated failure"):
        write_synthetic(target, lazy)
    assert _listing(tmp_path) == [target.name]
    with open_store(target) as reader:
        assert [record["name"] for record in reader.models()] == ["airplane_0001", "airplane_0002"]


@pytest.mark.parametrize("kind", KINDS)
def test_rewrite_replaces_the_store(tmp_path: Path, kind: str) -> None:
    target = write_synthetic(tmp_path / STORE_NAMES[kind])
    write_synthetic(target, synthetic_entries(MODELS[3:]), failures=[])
    assert _listing(tmp_path) == [target.name]
    with open_store(target) as reader:
        assert [record["name"] for record in reader.models()] == ["chair_0001", "chair_0002"]
        assert reader.failures() == [] and reader.attrs["n_failures"] == 0


def test_entry_that_changes_between_passes_is_rejected(tmp_path: Path) -> None:
    entries = synthetic_entries()

    class Drifting(LazyEntries):
        def __getitem__(self, index: int) -> ModelEntry:  # type: ignore[override]
            entry = super().__getitem__(index)
            if index == 2 and self.reads[index] == 2:
                return synthetic_entry(entry.category, entry.name, entry.split, seed=1)
            return entry

    with pytest.raises(VerificationError, match="airplane_0003"):
        write_synthetic(tmp_path / "d.zarr", Drifting(entries))
    assert _listing(tmp_path) == []


@pytest.mark.parametrize("kind", KINDS)
def test_zero_models(tmp_path: Path, kind: str) -> None:
    target = write_synthetic(tmp_path / STORE_NAMES[kind], [])
    with open_store(target) as reader:
        assert reader.attrs["n_models"] == 0 and reader.attrs["n_failures"] == 1
        assert reader.models() == [] and reader.failures() == FAILURES
        for name in ARRAY_NAMES:
            if name not in ("views", "models_json", "failures_json", "mesh_vertex_offsets",
                            "mesh_face_offsets"):
                assert reader.array(name).shape[0] == 0, name
            assert reader.stored_sha256(name) == array_sha256(reader.array(name)[...]), name
        np.testing.assert_array_equal(reader.array("mesh_vertex_offsets")[...], [0])
        with pytest.raises(IndexError):
            reader.entry(0)


def _renamed(entry: ModelEntry, **changes: Any) -> ModelEntry:
    fields = {key: getattr(entry, key) for key in entry.__dataclass_fields__}
    return ModelEntry(**{**fields, **changes})


def _bad_entries(case: str) -> list[ModelEntry]:
    entries = synthetic_entries()
    if case == "unsorted-names":
        entries[0], entries[1] = entries[1], entries[0]
    elif case == "unsorted-categories":
        entries = entries[3:] + entries[:3]
    elif case == "duplicate-in-category":
        entries[1] = _renamed(entries[1], name="airplane_0001")
    elif case == "duplicate-across-categories":
        entries[4] = _renamed(entries[4], name="airplane_0001")
    elif case == "bad-split":
        entries[0] = _renamed(entries[0], split="training")
    elif case == "bad-sha":
        entries[0] = _renamed(entries[0], source_sha256="ABC")
    elif case == "quality-rows":
        entries[0] = _renamed(entries[0], quality=entries[0].quality[:-1])
    elif case == "quality-range":
        entries[0] = _renamed(entries[0], quality=entries[0].quality * 2)
    elif case == "point-count":
        entries[2] = _renamed(entries[2], points=entries[2].points[:-1])
    elif case == "face-index":
        entries[0] = _renamed(entries[0], faces=entries[0].faces + len(entries[0].vertices))
    elif case == "float-faces":
        entries[0] = _renamed(entries[0], faces=entries[0].faces.astype(float))
    elif case == "best-index":
        entries[0] = _renamed(entries[0], best_index=np.array([0, 1, 2, N_VIEWS]))
    elif case == "nan-points":
        points = entries[0].points.copy()
        points[3, 1] = np.nan
        entries[0] = _renamed(entries[0], points=points)
    elif case == "zero-normals":
        entries[1] = _renamed(entries[1], normals=np.zeros_like(entries[1].normals))
    elif case == "long-normals":
        normals = entries[0].normals.copy()
        normals[5] *= 1.002  # beyond the tolerance of 0.001
        entries[0] = _renamed(entries[0], normals=normals)
    return entries


BAD_ENTRIES = {
    "unsorted-names": "airplane_0001.*sorted by \\(category, name\\)",
    "unsorted-categories": "airplane_0001.*sorted",
    "duplicate-in-category": "duplicate model name 'airplane_0001'",
    "duplicate-across-categories": "duplicate model name 'airplane_0001'",
    "bad-split": "split 'training'",
    "bad-sha": "source_sha256",
    "quality-rows": "quality: expected shape \\(50, 4\\)",
    "quality-range": "quality must be finite and in \\[0, 1\\]",
    "point-count": "airplane_0003', points: expected shape \\(200, 3\\)",
    "face-index": "faces refer to vertices",
    "float-faces": "faces: expected integers",
    "best-index": "best_index out of range",
    "nan-points": "points has NaN",
    "zero-normals": "'airplane_0002', 200 of 200 normals are not of unit length \\(the first, "
                    "normal 1, has length 0\\)$",
    "long-normals": "'airplane_0001', 1 of 200 normals are not of unit length \\(the first, "
                    "normal 6, has length 1.002\\)$",
}


@pytest.mark.parametrize("case", list(BAD_ENTRIES))
def test_bad_entries_are_rejected_before_writing(tmp_path: Path, case: str) -> None:
    with pytest.raises(InputError, match=BAD_ENTRIES[case]):
        write_synthetic(tmp_path / "d.zarr.zip", _bad_entries(case))
    assert _listing(tmp_path) == []


BAD_OPTIONS = {
    "missing-attr": ({"attrs": {k: v for k, v in BUILD.items() if k != "camera"}},
                     "missing root attributes \\['camera'\\]"),
    "writer-attr": ({"attrs": {**BUILD, "n_models": 7}}, "'n_models' is set by the writer"),
    "nan-attr": ({"attrs": {**BUILD, "resolution": float("nan")}}, "attrs: not JSON-safe"),
    "views-shape": ({"views": np.zeros((N_VIEWS, 2))}, "views: expected shape"),
    "views-unit": ({"views": fibonacci_sphere(N_VIEWS) * 2}, "views: expected unit vectors"),
    "failure-keys": ({"failures": [{"source": "a.off", "reason": "x"}]},
                     "failures\\[0\\]: expected exactly the keys"),
}


@pytest.mark.parametrize("case", list(BAD_OPTIONS))
def test_bad_options_are_rejected(tmp_path: Path, case: str) -> None:
    options, message = BAD_OPTIONS[case]
    with pytest.raises(InputError, match=message):
        write_synthetic(tmp_path / "d.h5", **options)
    assert _listing(tmp_path) == []


def test_bad_attributes_fail_before_any_entry_is_read(tmp_path: Path) -> None:
    lazy = LazyEntries(synthetic_entries())
    with pytest.raises(InputError, match="missing root attributes"):
        write_synthetic(tmp_path / "d.zarr", lazy, attrs={})
    assert lazy.reads == [0] * len(MODELS)


def test_writer_checks_the_target_path(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="unknown dataset format"):
        write_synthetic(tmp_path / "d.npz")
    with pytest.raises(InputError, match="output folder .* does not exist"):
        write_synthetic(tmp_path / "missing" / "d.h5")
    (tmp_path / "d.zarr").write_text("a file")
    with pytest.raises(InputError, match="exists and is not a directory"):
        write_synthetic(tmp_path / "d.zarr")


def test_progress_bar_goes_to_stderr(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_synthetic(tmp_path / "d.h5", progress=True)
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "d.h5: write" in captured.err


def test_no_stray_files_in_cwd(stores: dict[str, Path]) -> None:
    assert not any(name.endswith(".partial") for name in os.listdir(stores["zarr"].parent))


def test_zip_store_is_byte_reproducible(tmp_path: Path) -> None:
    """Two writes of the same data give identical bytes (a release's SHA256SUMS repeats)."""
    import hashlib
    import time

    digests = []
    for attempt in range(2):
        path = write_synthetic(tmp_path / f"{attempt}.zarr.zip")
        digests.append(hashlib.sha256(path.read_bytes()).hexdigest())
        time.sleep(2.1)  # zip timestamps have a 2 s resolution
    assert digests[0] == digests[1]


def test_a_zarr_directory_store_gets_the_umask_mode_not_0700(tmp_path: Path) -> None:
    build = write_build_to_pack(tmp_path / "build")
    mask = os.umask(0)
    os.umask(mask)
    assert (build / "dataset.zarr").stat().st_mode & 0o777 == 0o777 & ~mask


# --- a store of any registered measures ---------------------------------------------------


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
