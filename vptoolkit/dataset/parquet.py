"""Parquet shards of a release: one file per split, one row per model.

The archives (Zarr zip, HDF5) hold the whole layout of ``SCHEMA.md`` as a
handful of large arrays; dataset hubs and their libraries read rows. So a
release also carries, written with pyarrow:

- ``data/<split>-00000-of-00001.parquet``: one row per model of the split,
  the columns of :func:`model_columns`;
- ``views/views-00000-of-00001.parquet``: one row per view direction, shared
  by every model (:func:`view_columns`).

Splits use the names of :data:`vptoolkit.conventions.SPLITS`
(``train``, ``validation``, ``test``); an empty split gets no file. Arrays
of a fixed shape are nested lists (``list<list<float>>``, the storage of
Hugging Face's ``Array2D``); short vectors are fixed-size lists. Files are
zstd-compressed, one row group per 64 models, and the same store gives the
same bytes (same pyarrow version).

pyarrow is imported inside :func:`write_parquet_shards` (the ``dataset``
extra); nothing here is needed to read a release with :mod:`vptoolkit.data`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.conventions import MEASURES, SPLITS
from vptoolkit.dataset.schema import published_split
from vptoolkit.optional import require

if TYPE_CHECKING:
    from vptoolkit.dataset.reader import StoreReader

__all__ = [
    "PARQUET_FOLDER",
    "VIEWS_CONFIG",
    "Column",
    "ParquetShard",
    "model_columns",
    "view_columns",
    "shard_name",
    "write_parquet_shards",
]

PARQUET_FOLDER = "data"
"""Folder of the Parquet shards inside a release."""

VIEWS_CONFIG = "views"
"""Name of the shard (and hub configuration) holding the shared view directions."""

_ROWS_PER_GROUP = 64
_PROVENANCE = ("license", "author", "url")


@dataclass(frozen=True)
class Column:
    """One column of a shard.

    Attributes
    ----------
    name : str
        Column name.
    dtype : str
        ``"string"`` or a numpy dtype name (``"float32"``, ``"int64"``).
    shape : tuple
        ``()`` for a scalar, else the array shape per row; ``None`` marks a
        length that varies from row to row.
    description : str
        One line for the card and Croissant.
    """

    name: str
    dtype: str
    shape: tuple[int | None, ...]
    description: str


@dataclass(frozen=True)
class ParquetShard:
    """One written shard.

    Attributes
    ----------
    split : str
        Split name, or :data:`VIEWS_CONFIG`.
    path : str
        POSIX path relative to the release folder.
    n_rows : int
        Rows (models, or views).
    num_bytes : int
        Size of the rows as uncompressed Arrow data (the hub's ``num_bytes``).
    """

    split: str
    path: str
    n_rows: int
    num_bytes: int


def shard_name(split: str) -> str:
    """Relative path of the shard of ``split``, e.g. ``data/train-00000-of-00001.parquet``.

    The views shard goes in a folder of its own, ``views/``, so that
    ``data/*.parquet`` matches exactly the model shards.
    """
    folder = VIEWS_CONFIG if split == VIEWS_CONFIG else PARQUET_FOLDER
    return f"{folder}/{split}-00000-of-00001.parquet"


def model_columns(n_points: int, n_views: int) -> list[Column]:
    """The columns of a model shard, in file order.

    Parameters
    ----------
    n_points : int
        Points per model.
    n_views : int
        Views per model.

    Returns
    -------
    list of Column
    """
    order = ", ".join(MEASURES)
    n_measures = len(MEASURES)
    return [
        Column("name", "string", (), "unique model name"),
        Column("category", "string", (), "object category"),
        Column("split", "string", (), f"split: {', '.join(SPLITS)}"),
        Column("source", "string", (), "path of the source mesh inside the source dataset"),
        Column("source_sha256", "string", (), "SHA-256 of the source mesh file"),
        Column("license", "string", (), "licence of the source mesh (null if not given)"),
        Column("author", "string", (), "author or attribution of the source mesh"),
        Column("url", "string", (), "where the source mesh comes from"),
        Column("points", "float32", (n_points, 3), "points sampled by area on the cleaned mesh"),
        Column("normals", "float32", (n_points, 3), "unit face normal at each point"),
        Column("quality", "float32", (n_views, n_measures),
               f"normalised quality per view, columns {order}, 1 = best"),
        Column("quality_raw", "float32", (n_views, n_measures),
               f"raw measures per view, columns {order}, NaN where nothing is seen"),
        Column("best_index", "int64", (n_measures,), "index of the best view per measure"),
        Column("best_value", "float32", (n_measures,), "raw value at the best view"),
        Column("worst_index", "int64", (n_measures,), "index of the worst view per measure"),
        Column("worst_value", "float32", (n_measures,), "raw value at the worst view"),
        Column("mesh_vertices", "float32", (None, 3), "vertices of the cleaned mesh"),
        Column("mesh_faces", "int32", (None, 3), "triangles, indices into mesh_vertices"),
    ]


def view_columns() -> list[Column]:
    """The columns of the views shard: the index and the unit direction of each view."""
    return [
        Column("view_index", "int64", (), "index of the view, as in best_index"),
        Column("direction", "float64", (3,), "unit direction from the model centre to the camera"),
    ]


def _arrow_type(pa: Any, column: Column) -> Any:
    value = pa.string() if column.dtype == "string" else pa.from_numpy_dtype(np.dtype(column.dtype))
    if len(column.shape) == 1 and column.shape[0] is not None:
        return pa.list_(value, column.shape[0])  # fixed-size list
    for _ in column.shape:
        value = pa.list_(value)
    return value


def _nested(pa: Any, rows: list[NDArray[Any]], column: Column) -> Any:
    """Rows of equal inner shape as a (fixed-size) list array of the column's type."""
    dtype = np.dtype(column.dtype)
    if len(column.shape) == 1 and column.shape[0] is not None:
        flat = np.concatenate([np.asarray(r, dtype).reshape(-1) for r in rows]) if rows else (
            np.zeros(0, dtype))
        return pa.FixedSizeListArray.from_arrays(pa.array(flat), column.shape[0])
    inner = int(column.shape[-1] or 1)
    flat = (np.concatenate([np.asarray(r, dtype).reshape(-1) for r in rows]) if rows
            else np.zeros(0, dtype))
    n_inner = len(flat) // inner
    values = pa.ListArray.from_arrays(
        pa.array(np.arange(0, n_inner * inner + 1, inner, dtype=np.int32)), pa.array(flat))
    counts = [int(np.shape(r)[0]) for r in rows]
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
    return pa.ListArray.from_arrays(pa.array(offsets), values)


def _schema(pa: Any, columns: list[Column]) -> Any:
    return pa.schema([pa.field(c.name, _arrow_type(pa, c)) for c in columns])


def _write(pa: Any, pq: Any, path: Path, columns: list[Column],
           batches: Any) -> tuple[int, int]:
    """Write record batches to ``path``; return (rows, uncompressed Arrow bytes)."""
    schema = _schema(pa, columns)
    n_rows = num_bytes = 0
    with pq.ParquetWriter(path, schema, compression="zstd", compression_level=9,
                          write_statistics=False, store_schema=True) as writer:
        for arrays in batches:
            table = pa.Table.from_arrays(arrays, schema=schema)
            writer.write_table(table, row_group_size=_ROWS_PER_GROUP)
            n_rows += table.num_rows
            num_bytes += table.nbytes
    return n_rows, num_bytes


def _model_batches(pa: Any, reader: StoreReader, rows: list[int], columns: list[Column],
                   records: list[dict[str, Any]]) -> Any:
    vertex_offsets = np.asarray(reader.array("mesh_vertex_offsets")[...], np.int64)
    face_offsets = np.asarray(reader.array("mesh_face_offsets")[...], np.int64)
    for start in range(0, len(rows), _ROWS_PER_GROUP):
        chunk = rows[start : start + _ROWS_PER_GROUP]
        arrays = []
        for column in columns:
            if column.dtype == "string":
                values = [records[row].get(column.name) for row in chunk]
                if column.name == "split":
                    values = [published_split(str(v)) for v in values]
                arrays.append(pa.array([None if v is None else str(v) for v in values],
                                       pa.string()))
                continue
            if column.name == "mesh_vertices":
                block = [reader.array("mesh_vertices")[vertex_offsets[r] : vertex_offsets[r + 1]]
                         for r in chunk]
            elif column.name == "mesh_faces":
                block = [reader.array("mesh_faces")[face_offsets[r] : face_offsets[r + 1]]
                         for r in chunk]
            else:
                stored = reader.array(column.name)
                block = [stored[r] for r in chunk]
            arrays.append(_nested(pa, block, column))
        yield arrays


def write_parquet_shards(reader: StoreReader, release_dir: Path | str) -> list[ParquetShard]:
    """Write the Parquet shards of a store into ``release_dir/data/``.

    Parameters
    ----------
    reader : StoreReader
        The store to export (models in store order, which is sorted by
        category, then name).
    release_dir : Path or str
        The release folder (or its staging folder); ``data/`` is created.

    Returns
    -------
    list of ParquetShard
        The model shards in :data:`SPLITS` order (non-empty splits only),
        then the views shard.

    Raises
    ------
    MissingDependencyError
        If pyarrow is not installed (``pip install 'vptoolkit[dataset]'``).
    """
    pa = require("pyarrow", extra="dataset")
    pq = require("pyarrow.parquet", extra="dataset")
    folder = Path(release_dir)
    (folder / PARQUET_FOLDER).mkdir(parents=True, exist_ok=True)
    attrs = reader.attrs
    records = reader.models()
    for record in records:
        provenance = record.get("provenance") or {}
        for key in _PROVENANCE:
            record.setdefault(key, provenance.get(key) if isinstance(provenance, Mapping) else None)
    columns = model_columns(int(attrs["n_points"]), int(attrs["n_views"]))
    shards = []
    for split in SPLITS:
        rows = [row for row, record in enumerate(records)
                if published_split(str(record["split"])) == split]
        if not rows:
            continue
        relative = shard_name(split)
        n_rows, num_bytes = _write(pa, pq, folder / relative, columns,
                                   _model_batches(pa, reader, rows, columns, records))
        shards.append(ParquetShard(split, relative, n_rows, num_bytes))
    views = np.asarray(reader.array("views")[...], np.float64)
    view_cols = view_columns()
    relative = shard_name(VIEWS_CONFIG)
    (folder / VIEWS_CONFIG).mkdir(exist_ok=True)
    batch = [pa.array(np.arange(len(views), dtype=np.int64)),
             _nested(pa, list(views), view_cols[1])]
    n_rows, num_bytes = _write(pa, pq, folder / relative, view_cols, [batch])
    shards.append(ParquetShard(VIEWS_CONFIG, relative, n_rows, num_bytes))
    return shards
