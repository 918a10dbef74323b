"""The table of a collection run: one Parquet row per entry, the same bytes however it ran.

:func:`write_table` streams the staged records (see
:mod:`vptoolkit.collection.runner`) into ``table.parquet`` in row groups of
:data:`ROWS_PER_GROUP`, in the order the entries were discovered, so memory
stays bounded and the bytes depend only on the entries, their contents and
the method: never on the worker count, the scheduler, the order of
completion or a resume. Timings are kept out of it (``timings.jsonl``
beside it).

Columns
    ``file`` (the path read), ``key`` (the entry's path relative to the root
    given), ``sha256`` (of the file's bytes; empty when it could not be
    read), ``status`` (``ok`` or ``failed``), ``reason`` (one line, empty
    when ok), ``views`` (views drawn), ``label``; per name ``N`` of the
    method (a measure, or ``view_1``...): ``N_direction`` (3 float64, model
    centre towards the camera), ``N_raw`` (float64), ``N_pose`` (16 float64:
    the 4x4 camera-to-world pose, row-major, OpenCV convention); and
    ``intrinsics`` (9 float64: the 3x3 pinhole matrix, row-major). A failed
    row has nulls in the answer's columns.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vptoolkit.files import atomic_write
from vptoolkit.optional import require

__all__ = ["ROWS_PER_GROUP", "table_schema", "write_table", "write_table_predictions"]

ROWS_PER_GROUP = 1024
"""Rows per Parquet row group (and the most rows held in memory while writing)."""


def table_schema(names: Sequence[str]) -> Any:
    """The table's columns, a ``pyarrow.Schema``, for a method's direction ``names`` (see the
    module docstring)."""
    pa = require("pyarrow", extra="dataset")
    columns = [pa.field("file", pa.string()), pa.field("key", pa.string()),
               pa.field("sha256", pa.string()), pa.field("status", pa.string()),
               pa.field("reason", pa.string()), pa.field("views", pa.int64()),
               pa.field("label", pa.string())]
    for name in names:
        columns += [pa.field(f"{name}_direction", pa.list_(pa.float64(), 3)),
                    pa.field(f"{name}_raw", pa.float64()),
                    pa.field(f"{name}_pose", pa.list_(pa.float64(), 16))]
    columns.append(pa.field("intrinsics", pa.list_(pa.float64(), 9)))
    return pa.schema(columns)


def _columns(records: list[dict[str, Any]], names: Sequence[str]) -> dict[str, list[Any]]:
    columns: dict[str, list[Any]] = {
        "file": [r["file"] for r in records], "key": [r["key"] for r in records],
        "sha256": [r["sha256"] for r in records], "status": [r["status"] for r in records],
        "reason": [r["reason"] for r in records], "views": [r["views"] for r in records],
        "label": [r["label"] for r in records]}
    for column, name in enumerate(names):
        is_ok = [r["status"] == "ok" for r in records]
        columns[f"{name}_direction"] = [r["directions"][column] if ok else None
                                        for r, ok in zip(records, is_ok)]
        columns[f"{name}_raw"] = [r["raw"][column] if ok else None
                                  for r, ok in zip(records, is_ok)]
        columns[f"{name}_pose"] = [r["poses"][column] if ok else None
                                   for r, ok in zip(records, is_ok)]
    columns["intrinsics"] = [r["intrinsics"] if r["status"] == "ok" else None for r in records]
    return columns


def write_table(path: str | os.PathLike[str], records: Iterable[dict[str, Any]],
                names: Sequence[str]) -> Path:
    """Write staged records, in the order given, as ``path`` (atomically, in row groups).

    Parameters
    ----------
    path : path-like
        The ``.parquet`` file.
    records : iterable of dict
        The runner's staged records (``file``, ``key``, ``sha256``,
        ``status``, ``reason``, ``views``, ``label``, and for ok rows
        ``directions`` ``(n, 3)``, ``raw`` ``(n,)``, ``poses`` ``(n, 16)``,
        ``intrinsics`` ``(9,)`` as lists), read lazily.
    names : sequence of str
        The method's direction names.

    Returns
    -------
    Path
        ``path``.
    """
    pa = require("pyarrow", extra="dataset")
    pq = require("pyarrow.parquet", extra="dataset")
    schema = table_schema(names)
    target = Path(path)
    with atomic_write(target) as stream:
        writer = pq.ParquetWriter(stream, schema, compression="zstd")
        batch: list[dict[str, Any]] = []
        for record in records:
            batch.append(record)
            if len(batch) == ROWS_PER_GROUP:
                writer.write_table(pa.table(_columns(batch, names), schema=schema))
                batch = []
        if batch:
            writer.write_table(pa.table(_columns(batch, names), schema=schema))
        writer.close()
    return target


def write_table_predictions(table: str | os.PathLike[str],
                            path: str | os.PathLike[str]) -> Path | None:
    """Write the ok rows of a table as a predictions ``.npz``, named by key, in batches.

    Only for a table whose names are measures (a search or a measurement),
    as ``vptool evaluate`` scores them; a key listed twice counts once (its
    first row). The file is :func:`vptoolkit.predictions.write_predictions`'
    (the same bytes as from the keys and directions given as lists), built
    without a Python object per row: a first pass over the ``key`` and
    ``status`` columns counts the ok rows and their longest key, a second
    fills the ``names`` (fixed-width unicode, 4 bytes per character of the
    longest key) and ``directions`` ``(n, n_measures, 3)`` arrays a batch of
    :data:`ROWS_PER_GROUP` rows at a time. Memory is those two arrays, and
    while repeated keys are found (a stable sort of the names), about as
    much again plus 8 bytes per row: 10^7 keys of 40 characters take about
    1.6 GB of names.

    Returns
    -------
    Path or None
        ``path``, or None (nothing written) when no row is ok.
    """
    from vptoolkit.predictions import write_predictions

    pc = require("pyarrow.compute", extra="dataset")
    pq = require("pyarrow.parquet", extra="dataset")
    source = pq.ParquetFile(table)
    measures = tuple(column.removesuffix("_direction") for column in source.schema_arrow.names
                     if column.endswith("_direction"))
    n_ok = width = 0
    for batch in source.iter_batches(batch_size=ROWS_PER_GROUP, columns=["key", "status"]):
        ok = batch.column("key").filter(pc.equal(batch.column("status"), "ok"))
        n_ok += len(ok)
        if len(ok):
            width = max(width, pc.max(pc.utf8_length(ok)).as_py())
    if not n_ok:
        return None
    names = np.empty(n_ok, dtype=f"<U{width}")
    directions = np.empty((n_ok, len(measures), 3))
    row = 0
    columns = ["key", "status", *(f"{name}_direction" for name in measures)]
    for batch in source.iter_batches(batch_size=ROWS_PER_GROUP, columns=columns):
        ok = pc.equal(batch.column("status"), "ok")
        keys = batch.column("key").filter(ok)
        end = row + len(keys)
        names[row:end] = keys.to_numpy(zero_copy_only=False)
        for index, name in enumerate(measures):
            values = batch.column(f"{name}_direction").filter(ok).flatten()
            directions[row:end, index] = values.to_numpy().reshape(-1, 3)
        row = end
    order = np.argsort(names, kind="stable")  # a key's rows in table order
    ordered = names[order]
    repeated = order[1:][ordered[1:] == ordered[:-1]]  # a list may name a file twice
    del order, ordered
    if len(repeated):
        kept = np.ones(n_ok, dtype=bool)
        kept[repeated] = False
        names, directions = names[kept], directions[kept]
    return write_predictions(path, names, directions, measures=measures)
