"""Parquet shards of a release: files of bounded size per split, one row per model.

The archives (Zarr zip, HDF5) hold the whole layout of ``SCHEMA.md`` as a
handful of large arrays; dataset hubs and their libraries read rows. So a
release also carries, written with pyarrow:

- ``data/<split>-<i>-of-<n>.parquet`` (``data/train-00000-of-00012.parquet``,
  the hub's naming): one row per model of the split, the columns of
  :func:`model_columns`, in store order, cut into the fewest shards whose
  rows hold at most ``shard_bytes`` of Arrow data each (the measure the
  hub's ``max_shard_size`` uses; compressed files are smaller), at least one
  model per shard;
- ``views/views-00000-of-00001.parquet``: one row per view direction, shared
  by every model (:func:`view_columns`).

Splits use the names of :data:`vptoolkit.conventions.SPLITS`
(``train``, ``validation``, ``test``); an empty split gets no file. The
names hold no version, so a loader's paths stay valid across releases. Arrays
of a fixed shape are nested lists (``list<list<float>>``, the storage of
Hugging Face's ``Array2D``); short vectors are fixed-size lists. Files are
zstd-compressed, one row group per 64 models, and the same store gives the
same bytes (same pyarrow version).

Each shard describes itself as the card does: its schema metadata holds the
columns' :func:`hub_features` under the key ``huggingface``
(``{"info": {"features": ...}}``, as ``datasets`` writes it; JSON with
sorted keys). So ``datasets.load_dataset("parquet", data_files=shard)``
reads one shard alone with ``label`` a ``ClassLabel`` with the class names
and every string, number and vector column as declared. ``datasets`` takes
an ``Array2D`` from the metadata only for a column stored as its Arrow
extension type, which these plain lists are not (so that pandas and
mlcroissant read them alike with ``datasets`` imported or not): read alone,
the array columns are ``List(List(Value))`` of the same values.

pyarrow is imported inside :func:`write_parquet_shards` (the ``dataset``
extra); nothing here is needed to read a release with :mod:`vptoolkit.data`.

Size
    About 640 lines for one concept, the shard files: the columns
    (:class:`Column`; :func:`model_columns`, whose array columns are read
    off :data:`~vptoolkit.dataset.store.schema.ENTRY_ARRAYS`; their hub features), the
    writer and the check of written shards against the store
    (:func:`shard_differences`). The writer and the check walk the same
    column declarations value by value, so they stay beside them.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.conventions import SPLITS
from vptoolkit.dataset.store.schema import ARRAY_SPECS, ENTRY_ARRAYS, published_split
from vptoolkit.errors import ArgumentError
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.optional import require

if TYPE_CHECKING:
    from vptoolkit.dataset.store.reader import StoreReader

__all__ = [
    "DEFAULT_SHARD_BYTES",
    "PARQUET_FOLDER",
    "VIEWS_CONFIG",
    "parse_shard_name",
    "parse_size",
    "Column",
    "ParquetShard",
    "hub_features",
    "model_columns",
    "view_columns",
    "shard_name",
    "write_parquet_shards",
]

PARQUET_FOLDER = "data"
"""Folder of the Parquet shards inside a release."""

VIEWS_CONFIG = "views"
"""Name of the shard (and hub configuration) holding the shared view directions."""

DEFAULT_SHARD_BYTES = 500 * 1000**2
"""Largest Arrow size of the rows of one model shard, 500 MB (the hub's default)."""

_ROWS_PER_GROUP = 64
_STORED_AS = {"label": "labels"}  # column -> store array, where the names differ
_OFFSETS = {spec.name: spec.offsets for spec in ENTRY_ARRAYS if spec.per == "mesh"}
_PROVENANCE = ("license", "author", "url")
_SHARD = re.compile(r"(?P<folder>[a-z]+)/(?P<split>[a-z]+)-(?P<index>[0-9]{5})-of-"
                    r"(?P<count>[0-9]{5})\.parquet")
_SIZE = re.compile(r"\s*([0-9]+(?:\.[0-9]+)?)\s*([KMGT]?i?B?)\s*", re.IGNORECASE)
_UNITS = {"": 1, "B": 1, "KB": 1000, "MB": 1000**2, "GB": 1000**3, "TB": 1000**4,
          "KIB": 1024, "MIB": 1024**2, "GIB": 1024**3, "TIB": 1024**4}


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
    class_names : tuple of str, optional
        For a class label column: the category of each label (the hub's
        ``ClassLabel`` names, Croissant's category record set).
    """

    name: str
    dtype: str
    shape: tuple[int | None, ...]
    description: str
    class_names: tuple[str, ...] | None = None


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


def _shard_records(reader: Any) -> list[dict[str, Any]]:
    """The store's model records, provenance fields lifted to the top as shards hold them."""
    records = reader.models()
    for record in records:
        provenance = record.get("provenance") or {}
        for key in _PROVENANCE:
            record.setdefault(key, provenance.get(key) if isinstance(provenance, Mapping) else None)
    return records


def shard_name(split: str, index: int = 0, count: int = 1) -> str:
    """Relative path of shard ``index`` of ``count`` of ``split``.

    E.g. ``data/train-00003-of-00012.parquet``. The views shard goes in a
    folder of its own, ``views/``, so that ``data/*.parquet`` matches exactly
    the model shards.
    """
    folder = VIEWS_CONFIG if split == VIEWS_CONFIG else PARQUET_FOLDER
    return f"{folder}/{split}-{index:05d}-of-{count:05d}.parquet"


def parse_shard_name(relative: str) -> tuple[str, int, int] | None:
    """``(split, index, count)`` of a path :func:`shard_name` writes, else None."""
    match = _SHARD.fullmatch(relative)
    if match is None:
        return None
    split, index, count = match["split"], int(match["index"]), int(match["count"])
    if relative != shard_name(split, index, count) or index >= count:
        return None
    if split != VIEWS_CONFIG and split not in SPLITS:
        return None
    return split, index, count


def parse_size(text: str | int, label: str = "--shard-size") -> int:
    """Bytes from a size: ``200KB``, ``500MB``, ``1.5GB``, ``64MiB`` or a plain number.

    KB, MB, GB and TB are powers of 1000, KiB, MiB, GiB and TiB of 1024.

    Raises
    ------
    ArgumentError
        For anything else, or a size under one byte, naming ``label``.
    """
    if isinstance(text, int) and not isinstance(text, bool):
        value = float(text)
    else:
        match = _SIZE.fullmatch(str(text))
        unit = match[2].upper() if match else ""
        if match is None or unit not in _UNITS:
            raise ArgumentError(f"{{argument}}: {text!r} is not a size such as 200KB, 500MB "
                                "or 1GB", label)
        value = float(match[1]) * _UNITS[unit]
    if value < 1:
        raise ArgumentError(f"{{argument}}: {text!r} is under one byte", label)
    return int(value)


def model_columns(n_points: int, n_views: int, class_names: Sequence[str] | None = None, *,
                  measures: Sequence[str] = PAPER_MEASURES) -> list[Column]:
    """The columns of a model shard, in file order.

    The model's record (``name``, ``category``, its class ``label``,
    ``split``, ``source`` and its digest, the provenance fields), then one
    column per array a :class:`~vptoolkit.dataset.store.schema.ModelEntry`
    carries (:data:`~vptoolkit.dataset.store.schema.ENTRY_ARRAYS`: their
    names, dtypes, shapes and column descriptions), in store order.

    Parameters
    ----------
    n_points : int
        Points per model.
    n_views : int
        Views per model.
    class_names : sequence of str, optional
        The store's ``class_names``, kept on the ``label`` column (for the
        card and Croissant; the shard itself stores the integer).
    measures : sequence of str
        The store's ``measures``: the measure arrays hold one column per name
        (``quality`` is ``(n_views, K)``), and their descriptions list the
        names (default: the paper's four).

    Returns
    -------
    list of Column
    """
    labels = ARRAY_SPECS["labels"]
    sizes = {"n_points": n_points, "n_views": n_views, "n_measures": len(measures)}
    return [
        Column("name", "string", (), "unique model name"),
        Column("category", "string", (), "object category"),
        Column("label", labels.dtype, (), labels.column,
               None if class_names is None else tuple(class_names)),
        Column("split", "string", (), f"split: {', '.join(SPLITS)}"),
        Column("source", "string", (), "path of the source mesh inside the source dataset"),
        Column("source_sha256", "string", (), "SHA-256 of the source mesh file"),
        Column("license", "string", (), "licence of the source mesh (null if not given)"),
        Column("author", "string", (), "author or attribution of the source mesh"),
        Column("url", "string", (), "where the source mesh comes from"),
        *(Column(spec.name, spec.dtype, spec.resolve(sizes), spec.column_for(measures))
          for spec in ENTRY_ARRAYS),
    ]


def view_columns() -> list[Column]:
    """The columns of the views shard: the index and the unit direction of each view."""
    return [
        Column("view_index", "int64", (), "index of the view, as in best_index"),
        Column("direction", "float64", (3,), "unit direction from the model centre to the camera"),
    ]


def hub_features(columns: Sequence[Column]) -> dict[str, Any]:
    """The columns as Hugging Face ``datasets`` features, the form of ``Features.to_dict()``.

    A column with class names is a ``ClassLabel``, a scalar a ``Value``, a
    vector a ``List`` (of fixed length where the shape says one), an array
    of two or more axes an ``Array2D`` (``Array3D``, ...) whose first axis
    may vary. The card's ``dataset_info`` declares the same features in the
    hub's YAML.

    Parameters
    ----------
    columns : sequence of Column
        E.g. :func:`model_columns` or :func:`view_columns`.

    Returns
    -------
    dict
        Column name to feature dict, in column order;
        ``datasets.Features.from_dict`` reads it.
    """
    features: dict[str, Any] = {}
    for column in columns:
        value = {"_type": "Value", "dtype": column.dtype}
        if column.class_names is not None:
            features[column.name] = {"_type": "ClassLabel", "names": list(column.class_names)}
        elif not column.shape:
            features[column.name] = value
        elif len(column.shape) == 1:
            length = {} if column.shape[0] is None else {"length": column.shape[0]}
            features[column.name] = {"_type": "List", "feature": value, **length}
        else:
            features[column.name] = {"_type": f"Array{len(column.shape)}D", "dtype": column.dtype,
                                     "shape": list(column.shape)}
    return features


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
    if not column.shape:
        return pa.array(np.asarray(rows, dtype).reshape(-1))
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
    """The Arrow schema of a shard, with its ``datasets`` features as schema metadata."""
    info = json.dumps({"info": {"features": hub_features(columns)}}, sort_keys=True)
    return pa.schema([pa.field(c.name, _arrow_type(pa, c)) for c in columns],
                     metadata={b"huggingface": info.encode()})


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
    offsets = _mesh_offsets(reader)
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
            if column.name in offsets:
                stored, bounds = reader.array(column.name), offsets[column.name]
                block = [stored[bounds[r] : bounds[r + 1]] for r in chunk]
            else:
                stored = _per_model(reader, column)
                block = [stored[r] for r in chunk]
            arrays.append(_nested(pa, block, column))
        yield arrays


def _mesh_offsets(reader: StoreReader) -> dict[str, NDArray[np.int64]]:
    """The row offsets of each mesh column's store array (model ``m`` owns rows
    ``o[m]:o[m + 1]``), by column name."""
    return {name: np.asarray(reader.array(offsets)[...], np.int64)
            for name, offsets in _OFFSETS.items()}


def _per_model(reader: StoreReader, column: Column) -> Any:
    """The store's array behind a column; one read whole when it holds one value a model
    (``labels``: a chunk of it would be decoded again for every row)."""
    stored = reader.array(_STORED_AS.get(column.name, column.name))
    return np.asarray(stored[...]) if len(stored.shape) == 1 else stored


def _row_bytes(columns: list[Column], records: list[dict[str, Any]], rows: list[int],
               lengths: Mapping[str, NDArray[Any]]) -> list[int]:
    """The Arrow size of each row as read back from Parquet, at most.

    Values, the 4-byte offsets of every list and a validity bit per element
    at every level of a column (a table read from Parquet has a validity
    bitmap at each level, nulls or not), with a byte per level for the
    rounding of a bitmap.
    """
    fixed = 0
    for column in columns:
        dims = [d for d in column.shape if d is not None]
        if column.dtype == "string" or len(dims) < len(column.shape):
            continue
        fixed += int(np.prod(dims)) * np.dtype(column.dtype).itemsize
        if len(dims) == 2:
            fixed += 4 * (dims[0] + 1)
    sizes = []
    for row in rows:
        size = fixed
        validity_bits = 0
        for column in columns:
            if column.dtype == "string":
                value = records[row].get(column.name)
                size += 4 + (0 if value is None else len(str(value).encode("utf-8")))
            elif None in column.shape:
                n = int(lengths[column.name][row])
                size += n * int(column.shape[-1] or 1) * np.dtype(column.dtype).itemsize
                size += 4 * (n + 1)
            elements = 1  # the row, then every element of each list level
            validity_bits += elements + 8  # + 8: a byte of rounding per level
            for dim in column.shape:
                elements *= int(lengths[column.name][row]) if dim is None else dim
                validity_bits += elements + 8
        sizes.append(size + -(-validity_bits // 8))
    return sizes


def _cut(rows: list[int], sizes: list[int], limit: int) -> list[list[int]]:
    """Consecutive rows in the fewest groups of at most ``limit`` bytes (at least one row each)."""
    groups: list[list[int]] = []
    current: list[int] = []
    total = 0
    for row, size in zip(rows, sizes):
        if current and total + size > limit:
            groups.append(current)
            current, total = [], 0
        current.append(row)
        total += size
    if current:
        groups.append(current)
    return groups


def write_parquet_shards(reader: StoreReader, release_dir: Path | str, *,
                         shard_bytes: int = DEFAULT_SHARD_BYTES) -> list[ParquetShard]:
    """Write the Parquet shards of a store into ``release_dir/data/``.

    Parameters
    ----------
    reader : StoreReader
        The store to export (models in store order, which is sorted by
        category, then name).
    release_dir : Path or str
        The release folder (or its staging folder); ``data/`` is created.
    shard_bytes : int
        Largest Arrow size of the rows of one model shard (default 500 MB);
        a model larger than that gets a shard of its own.

    Returns
    -------
    list of ParquetShard
        The model shards in :data:`SPLITS` order (non-empty splits only),
        each split's in file order, then the views shard.

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
    records = _shard_records(reader)
    columns = model_columns(int(attrs["n_points"]), int(attrs["n_views"]),
                            reader.class_labels()[0], measures=reader.measures)
    lengths = {name: np.diff(offsets) for name, offsets in _mesh_offsets(reader).items()}
    shards = []
    for split in SPLITS:
        rows = [row for row, record in enumerate(records)
                if published_split(str(record["split"])) == split]
        if not rows:
            continue
        groups = _cut(rows, _row_bytes(columns, records, rows, lengths), shard_bytes)
        for index, group in enumerate(groups):
            relative = shard_name(split, index, len(groups))
            n_rows, num_bytes = _write(pa, pq, folder / relative, columns,
                                       _model_batches(pa, reader, group, columns, records))
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


def _shard_values(pa: Any, array: Any, column: Column) -> list[NDArray[Any]]:
    """The rows of one column of a record batch as numpy arrays of the column's dtype."""
    dtype = np.dtype(column.dtype)
    if isinstance(array, pa.ChunkedArray):
        array = array.combine_chunks()
    if array.null_count:
        raise ValueError("null values")
    if not column.shape:
        return list(array.to_numpy(zero_copy_only=False).astype(dtype))
    lengths = np.asarray(array.value_lengths().to_numpy(zero_copy_only=False), np.int64)
    flat = array.flatten()
    if len(column.shape) == 2:
        inner = pa.compute.list_value_length(flat).to_numpy(zero_copy_only=False)
        if flat.null_count or np.any(inner != column.shape[1]):
            raise ValueError(f"rows are not of {column.shape[1]} values")
        flat = flat.flatten()
    values = np.asarray(flat.to_numpy(zero_copy_only=False), dtype)
    inner_size = int(column.shape[-1] or 1) if len(column.shape) == 2 else 1
    bounds = np.concatenate([[0], np.cumsum(lengths)]) * inner_size
    rows = [values[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
    return [row.reshape(-1, inner_size) if len(column.shape) == 2 else row for row in rows]


def _same(expected: Any, found: Any, dtype: str) -> bool:
    if dtype == "string":
        return expected == found
    left = np.asarray(expected, np.dtype(dtype))
    right = np.asarray(found)
    if left.size != right.size:
        return False
    left, right = left.reshape(-1), right.reshape(-1)
    return bool(np.array_equal(left, right, equal_nan=left.dtype.kind == "f"))


def shard_differences(reader: StoreReader, release_dir: Path | str,
                      shards: list[str]) -> list[tuple[str, str]]:
    """Compare Parquet shards, row by row, with the store they were written from.

    Parameters
    ----------
    reader : StoreReader
        An archive of the release.
    release_dir : Path or str
        The release folder.
    shards : list of str
        The shards to compare, as paths relative to ``release_dir``
        (:func:`shard_name`; other names are left alone).

    Returns
    -------
    list of (str, str)
        ``(target, detail)`` per difference; the target is ``<shard>`` or
        ``<shard>:<model>:<column>``. Empty when every shard holds what the
        store holds.

    Raises
    ------
    MissingDependencyError
        If pyarrow is not installed.
    """
    require("pyarrow.compute", extra="dataset")
    pa = require("pyarrow", extra="dataset")
    pq = require("pyarrow.parquet", extra="dataset")
    folder = Path(release_dir)
    attrs = reader.attrs
    records = _shard_records(reader)
    names = [str(record["name"]) for record in records]
    by_split = {split: [row for row, record in enumerate(records)
                        if published_split(str(record["split"])) == split] for split in SPLITS}
    model_cols = model_columns(int(attrs["n_points"]), int(attrs["n_views"]),
                               measures=reader.measures)
    groups: dict[str, list[tuple[str, int]]] = {}
    for relative in sorted(shards):
        parsed = parse_shard_name(relative)
        if parsed is not None:  # other names are not files of this layout
            groups.setdefault(parsed[0], []).append((relative, parsed[2]))
    found: list[tuple[str, str]] = []
    for split, listed in groups.items():
        files = [relative for relative, _ in listed]
        label = files[0] if len(files) == 1 else f"{PARQUET_FOLDER}/{split}-*.parquet"
        counts = {count for _, count in listed}
        if len(counts) != 1 or len(files) != counts.pop():
            found.append((label, f"shards of split {split!r} do not form one complete set"))
            continue
        columns = view_columns() if split == VIEWS_CONFIG else model_cols
        try:
            tables = [pq.read_table(folder / relative) for relative in files]
            missing = sorted({c.name for c in columns for table in tables
                              if c.name not in table.column_names})
            if missing:
                found.append((label, f"columns missing: {', '.join(missing)}"))
                continue
            table = pa.concat_tables([t.select([c.name for c in columns]) for t in tables])
            where = [relative for relative, t in zip(files, tables) for _ in range(t.num_rows)]
            if split == VIEWS_CONFIG:
                views = np.asarray(reader.array("views")[...], np.float64)
                index = _shard_values(pa, table.column("view_index"), columns[0])
                direction = _shard_values(pa, table.column("direction"), columns[1])
                if not (_same(np.arange(len(views)), index, "int64")
                        and _same(views, direction, "float64")):
                    found.append((label, "view directions differ from the archive's"))
                continue
            rows = by_split[split]
            shard_names = [str(v) for v in table.column("name").to_pylist()]
            if shard_names != [names[row] for row in rows]:
                found.append((label, f"models differ from the archive's {split} split "
                                     f"({len(shard_names)} rows, {len(rows)} models)"))
                continue
            found += _row_differences(pa, reader, table, columns, records, rows, where)
        except Exception as err:  # noqa: BLE001 - a shard that cannot be read is the finding
            found.append((label, f"cannot be compared ({type(err).__name__}: {err})"))
    return found


def _row_differences(pa: Any, reader: StoreReader, table: Any, columns: list[Column],
                     records: list[dict[str, Any]], rows: list[int],
                     where: list[str]) -> list[tuple[str, str]]:
    """``(<shard>:<model>:<column>, detail)`` for each value of ``table`` unlike the store's."""
    found = []
    offsets = _mesh_offsets(reader)
    for column in columns:
        if column.dtype == "string":
            values: list[Any] = table.column(column.name).to_pylist()
        else:
            values = _shard_values(pa, table.column(column.name), column)
        if column.name in offsets:
            stored = reader.array(column.name)
        elif column.dtype != "string":
            stored = _per_model(reader, column)
        for position, row in enumerate(rows):
            if column.dtype == "string":
                expected: Any = records[row].get(column.name)
                if column.name == "split":
                    expected = published_split(str(expected))
                expected = None if expected is None else str(expected)
            elif column.name in offsets:
                bounds = offsets[column.name]
                expected = stored[bounds[row] : bounds[row + 1]]
            else:
                expected = stored[row]
            if not _same(expected, values[position], column.dtype):
                found.append((f"{where[position]}:{records[row]['name']}:{column.name}",
                              "differs from the archive"))
    return found
