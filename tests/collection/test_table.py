"""The table of a collection: its columns, nulls for failures, predictions by key."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from vptoolkit.collection.table import (
    ROWS_PER_GROUP,
    table_schema,
    write_table,
    write_table_predictions,
)
from vptoolkit.predictions import read_predictions, write_predictions


def _ok(key: str, direction: list[float]) -> dict:
    return {"file": f"/data/{key}", "key": key, "sha256": "0" * 64, "status": "ok",
            "reason": "", "views": 8, "label": "searched VE (8 views)",
            "directions": [direction], "raw": [1.5], "poses": [list(np.eye(4).ravel())],
            "intrinsics": list(np.eye(3).ravel())}


def test_columns_per_name_and_nulls_for_a_failure(tmp_path: Path):
    assert table_schema(("VE",)).names == ["file", "key", "sha256", "status", "reason", "views",
                                           "label", "VE_direction", "VE_raw", "VE_pose",
                                           "intrinsics"]
    failed = {"file": "/data/b.off", "key": "b.off", "sha256": "", "status": "failed",
              "reason": "b.off: empty", "views": 0, "label": ""}
    path = write_table(tmp_path / "table.parquet", iter([_ok("a.off", [0.0, 0.0, 1.0]), failed]),
                       ("VE",))
    import pyarrow.parquet as pq

    rows = pq.read_table(path).to_pylist()
    assert rows[0]["VE_direction"] == [0.0, 0.0, 1.0] and rows[0]["VE_pose"][0] == 1.0
    assert rows[1]["VE_direction"] is None and rows[1]["intrinsics"] is None
    npz = write_table_predictions(path, tmp_path / "predictions.npz")
    assert npz is not None
    predictions = read_predictions(npz)
    assert predictions.names == ("a.off",) and predictions.measures == ("VE",)
    assert predictions.directions.tolist() == [[[0.0, 0.0, 1.0]]]
    only_failed = write_table(tmp_path / "failed.parquet", iter([failed]), ("VE",))
    assert write_table_predictions(only_failed, tmp_path / "none.npz") is None
    assert not (tmp_path / "none.npz").exists()


def _members(npz: Path) -> dict[str, bytes]:
    """Each array of an ``.npz`` as its ``.npy`` bytes (the zip's own dates vary)."""
    with zipfile.ZipFile(npz) as archive:
        return {name: archive.read(name) for name in archive.namelist()}


def test_predictions_in_batches_are_the_arrays_of_the_keys_as_a_list(tmp_path: Path):
    # rows over several batches: keys of different widths, non-ASCII ones, failures and a
    # key listed again, whose first row counts
    records = []
    for number in range(2 * ROWS_PER_GROUP + 300):
        key = f"{'é' * (number % 7)}{number}.off"
        direction = [float(number), 0.5, -1.0]
        records.append(_ok(key, direction) if number % 5 else
                       {"file": f"/data/{key}", "key": key, "sha256": "", "status": "failed",
                        "reason": f"{key}: empty", "views": 0, "label": ""})
    records.append(_ok("é1.off", [9.0, 9.0, 9.0]))  # the key of row 1 again
    for record in records:
        if record["status"] == "ok":
            record.update(directions=[record["directions"][0], [0.0, 1.0, 0.0]],
                          raw=[1.5, 2.5], poses=[record["poses"][0]] * 2)
    table = write_table(tmp_path / "table.parquet", iter(records), ("VE", "VR"))
    npz = write_table_predictions(table, tmp_path / "predictions.npz")
    assert npz is not None
    seen: dict[str, list] = {}
    for record in records:  # the old way: Python lists of the ok rows, first of a key
        if record["status"] == "ok":
            seen.setdefault(record["key"], record["directions"])
    expected = write_predictions(tmp_path / "expected.npz", list(seen), list(seen.values()),
                                 measures=("VE", "VR"))
    assert _members(npz) == _members(expected)
    predictions = read_predictions(npz)
    assert predictions.names[0] == "é1.off" and len(predictions.names) == len(seen)
    assert predictions.directions[0, 0].tolist() == [1.0, 0.5, -1.0]  # its first row


def test_the_same_records_give_the_same_bytes(tmp_path: Path):
    records = [_ok(f"m{number}.off", [1.0, 0.0, 0.0]) for number in range(3000)]
    first = write_table(tmp_path / "a.parquet", iter(records), ("VE",)).read_bytes()
    assert write_table(tmp_path / "b.parquet", iter(records), ("VE",)).read_bytes() == first
