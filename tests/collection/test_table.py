"""The table of a collection: its columns, nulls for failures, predictions by key."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vptoolkit.collection.table import read_predictions, table_schema, write_table


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
    predictions = read_predictions(path)
    assert predictions.names == ("a.off",) and predictions.measures == ("VE",)
    assert predictions.directions.shape == (1, 1, 3)


def test_the_same_records_give_the_same_bytes(tmp_path: Path):
    records = [_ok(f"m{number}.off", [1.0, 0.0, 0.0]) for number in range(3000)]
    first = write_table(tmp_path / "a.parquet", iter(records), ("VE",)).read_bytes()
    assert write_table(tmp_path / "b.parquet", iter(records), ("VE",)).read_bytes() == first
