"""The on-disk layout of the viewpoint-quality dataset (schema version 1).

One layout, described in ``dataset_card/SCHEMA.md``, stored in one of three
containers chosen by the file name:

========================  =========  ==========================================
suffix                    ``kind``   container
========================  =========  ==========================================
``*.zarr``                zarr       Zarr v3 directory (Blosc/zstd chunks)
``*.zarr.zip``            zarr-zip   the same Zarr v3 hierarchy in a zip file
``*.h5``, ``*.hdf5``      hdf5       HDF5 file (gzip level 4 with shuffle)
========================  =========  ==========================================

All three hold the same arrays with the same names, shapes, dtypes and
``sha256`` attributes. Text is UTF-8 JSON in ``uint8`` arrays; nothing is
pickled and no array has object dtype.

HDF5 cannot hold nested attributes, so in an HDF5 file every root attribute
that is not a ``str``, ``bool``, ``int`` or ``float`` (``measures``,
``higher_is_better``, ``camera``, ``cleaning``, ``split_fractions``, ...) is
stored as a JSON string, and the root attribute ``json_attributes`` (itself a
JSON list) names those keys. :class:`StoreReader` decodes them, so
``StoreReader.attrs`` is the same dictionary for every container.

``zarr`` and ``h5py`` are imported inside the functions that need them, and
only the one for the container in use.

This module owns the public API: the container a path names
(:func:`store_kind`, :func:`find_store`, :func:`zarr_is_usable`), writing
(:func:`write_dataset`: checking entries, chunk layout, atomic replacement)
and reading (:func:`open_store`, :class:`StoreReader`, root checks). The data
contract lives in :mod:`vptoolkit.dataset.schema` and is re-exported here; each
container's own reading and writing lives in :mod:`vptoolkit.dataset._zarr` and
:mod:`vptoolkit.dataset._hdf5`, imported inside the functions that use them.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import os
import re
import shutil
import tempfile
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.conventions import HIGHER_IS_BETTER, MEASURES
from vptoolkit.dataset.schema import (
    ARRAY_NAMES,
    BUILD_ATTRS,
    FAILURE_KEYS,
    FORMAT_NAME,
    HDF5_JSON_KEY,
    SCHEMA_VERSION,
    SPLIT_ALIASES,
    SPLITS,
    WRITER_ATTRS,
    ModelEntry,
    array_sha256,
    from_json_bytes,
    json_bytes,
    le_bytes,
    published_split,
)
from vptoolkit.errors import InputError, MissingDependencyError, VerificationError
from vptoolkit.files import remove_stale_partials, temporary_prefix
from vptoolkit.optional import is_available, require
from vptoolkit.progress import Bar, progress_bar

__all__ = [
    "FORMAT_NAME",
    "SCHEMA_VERSION",
    "ARRAY_NAMES",
    "BUILD_ATTRS",
    "WRITER_ATTRS",
    "SPLITS",
    "SPLIT_ALIASES",
    "published_split",
    "FAILURE_KEYS",
    "ModelEntry",
    "write_dataset",
    "StoreReader",
    "open_store",
    "find_store",
    "store_kind",
    "array_sha256",
    "json_bytes",
    "from_json_bytes",
    "zarr_is_usable",
]

_CHUNK_MODELS = 64  # models per chunk of the per-model arrays other than points/normals
_CHUNK_ROWS = 1 << 16  # rows per chunk of the concatenated mesh arrays and the offsets
_CHUNK_BYTES = 1 << 22  # bytes per chunk of the JSON arrays
_SHA256_HEX = re.compile(r"[0-9a-f]{64}")


# --------------------------------------------------------------------------- paths


def store_kind(path: str | os.PathLike[str]) -> str:
    """The container a store path names, from its suffix.

    Returns
    -------
    kind : str
        ``"zarr"`` for ``*.zarr``, ``"zarr-zip"`` for ``*.zarr.zip``,
        ``"hdf5"`` for ``*.h5`` and ``*.hdf5``.

    Raises
    ------
    InputError
        For any other suffix.
    """
    name = Path(path).name.lower()
    if name.endswith(".zarr.zip"):
        return "zarr-zip"
    if name.endswith(".zarr"):
        return "zarr"
    if name.endswith((".h5", ".hdf5")):
        return "hdf5"
    raise InputError(
        f"{Path(path).name}: unknown dataset format, expected *.zarr, *.zarr.zip, *.h5 or *.hdf5"
    )


def find_store(path: str | os.PathLike[str]) -> Path:
    """Locate the store a path refers to.

    Parameters
    ----------
    path : path-like
        One of: a store itself (``*.zarr``, ``*.zarr.zip``, ``*.h5``,
        ``*.hdf5``); a build output folder holding ``dataset.zarr`` or
        ``dataset.h5``; a release folder holding exactly one ``*.zarr.zip``
        (preferred) or else exactly one ``*.h5`` / ``*.hdf5``. Hidden names
        (temporary files of an unfinished write) are ignored.

    Returns
    -------
    store : pathlib.Path
        Path of the store.

    Raises
    ------
    InputError
        If the path does not exist or no single store can be chosen.
    """
    target = Path(path)
    if not target.exists():
        raise InputError(f"{target}: no such file or directory")
    is_store_name = True
    try:
        store_kind(target)
    except InputError:
        is_store_name = False
    if is_store_name and (target.is_dir() == (store_kind(target) == "zarr")):
        return target
    if not target.is_dir():
        raise InputError(f"{target}: not a dataset store (*.zarr, *.zarr.zip, *.h5) or folder")
    built = [target / name for name in ("dataset.zarr", "dataset.h5") if (target / name).exists()]
    if len(built) == 2:
        raise InputError(f"{target}: holds both dataset.zarr and dataset.h5; pass one of them")
    if built:
        return built[0]
    visible = sorted(p for p in target.iterdir() if not p.name.startswith("."))
    containers: list[tuple[str, ...]] = [(".zarr.zip",), (".h5", ".hdf5")]
    if not zarr_is_usable() and is_available("h5py"):
        containers.reverse()  # a release holds both: open the one this install can read
    for suffixes in containers:
        found = [p for p in visible if p.is_file() and p.name.lower().endswith(suffixes)]
        if len(found) == 1:
            return found[0]
        if len(found) > 1:
            names = ", ".join(p.name for p in found)
            raise InputError(f"{target}: holds {len(found)} stores ({names}); pass one of them")
    raise InputError(
        f"{target}: no dataset.zarr, dataset.h5, *.zarr.zip or *.h5 store in this folder"
    )


# --------------------------------------------------------------------------- writing


class _Checked(NamedTuple):
    """One entry's arrays cast to the stored dtypes, in the order they are written."""

    record: dict[str, Any]
    arrays: dict[str, NDArray[Any]]


_ENTRY_ARRAYS = {
    # stored array name: (ModelEntry field, dtype)
    "points": ("points", np.dtype("<f4")),
    "normals": ("normals", np.dtype("<f4")),
    "quality": ("quality", np.dtype("<f4")),
    "quality_raw": ("quality_raw", np.dtype("<f4")),
    "best_index": ("best_index", np.dtype("<i8")),
    "best_value": ("best_value", np.dtype("<f4")),
    "worst_index": ("worst_index", np.dtype("<i8")),
    "worst_value": ("worst_value", np.dtype("<f4")),
    "mesh_vertices": ("vertices", np.dtype("<f4")),
    "mesh_faces": ("faces", np.dtype("<i4")),
}


def _cast(entry_name: str, field: str, value: Any, dtype: np.dtype[Any],
          shape: tuple[int | None, ...]) -> NDArray[Any]:
    where = f"entries: model {entry_name!r}, {field}"
    try:
        source = np.asarray(value)
    except (TypeError, ValueError) as err:
        raise InputError(f"{where}: not an array ({err})") from err
    if source.dtype.kind not in "iuf":
        raise InputError(f"{where}: expected a numeric array, got dtype {source.dtype}")
    if dtype.kind in "iu" and source.dtype.kind == "f":
        raise InputError(f"{where}: expected integers, got dtype {source.dtype}")
    if source.ndim != len(shape) or any(
        want is not None and got != want for got, want in zip(source.shape, shape)
    ):
        expected = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise InputError(f"{where}: expected shape {expected}, got {source.shape}")
    if dtype.kind in "iu" and source.size and dtype.itemsize < source.dtype.itemsize:
        info = np.iinfo(dtype)
        if source.min() < info.min or source.max() > info.max:
            raise InputError(f"{where}: values do not fit in {dtype.name}")
    return np.ascontiguousarray(source, dtype=dtype)


def _check_entry(entry: Any, position: int, n_views: int, n_points: int | None) -> _Checked:
    """Validate one entry and cast its arrays; ``n_points`` None accepts any count."""
    if not isinstance(entry, ModelEntry):
        raise InputError(f"entries[{position}]: expected a ModelEntry, got {type(entry).__name__}")
    for field in ("name", "category", "split", "source", "source_sha256"):
        value = getattr(entry, field)
        if not isinstance(value, str) or not value:
            raise InputError(
                f"entries[{position}]: {field} must be a non-empty string, got {value!r}"
            )
    name = entry.name
    if published_split(entry.split) not in SPLITS:
        raise InputError(f"entries: model {name!r}, split {entry.split!r} is not one of {SPLITS}")
    if not _SHA256_HEX.fullmatch(entry.source_sha256):
        raise InputError(f"entries: model {name!r}, source_sha256 is not 64 lower-case hex digits")
    arrays = {
        "points": _cast(name, "points", entry.points, _ENTRY_ARRAYS["points"][1], (n_points, 3)),
    }
    n_points = arrays["points"].shape[0]
    if n_points < 1:
        raise InputError(f"entries: model {name!r}, points is empty")
    shapes: dict[str, tuple[int | None, ...]] = {
        "normals": (n_points, 3),
        "quality": (n_views, len(MEASURES)),
        "quality_raw": (n_views, len(MEASURES)),
        "best_index": (len(MEASURES),),
        "best_value": (len(MEASURES),),
        "worst_index": (len(MEASURES),),
        "worst_value": (len(MEASURES),),
        "mesh_vertices": (None, 3),
        "mesh_faces": (None, 3),
    }
    for stored, shape in shapes.items():
        field, dtype = _ENTRY_ARRAYS[stored]
        arrays[stored] = _cast(name, field, getattr(entry, field), dtype, shape)
    for field in ("points", "normals", "mesh_vertices"):
        if not np.isfinite(arrays[field]).all():
            raise InputError(f"entries: model {name!r}, {field} has NaN or infinite values")
    quality = arrays["quality"]
    if not (np.isfinite(quality).all() and (quality >= 0).all() and (quality <= 1).all()):
        raise InputError(f"entries: model {name!r}, quality must be finite and in [0, 1]")
    for field in ("best_index", "worst_index"):
        index = arrays[field]
        if ((index < 0) | (index >= n_views)).any():
            raise InputError(f"entries: model {name!r}, {field} out of range [0, {n_views})")
    faces = arrays["mesh_faces"]
    n_vertices = arrays["mesh_vertices"].shape[0]
    if faces.size and (faces.min() < 0 or faces.max() >= n_vertices):
        raise InputError(
            f"entries: model {name!r}, faces refer to vertices outside [0, {n_vertices})"
        )
    if entry.cleaning is not None and not isinstance(entry.cleaning, dict):
        raise InputError(f"entries: model {name!r}, cleaning must be a dict or None")
    record = entry.record()
    try:
        json.dumps(record, allow_nan=False)
    except (TypeError, ValueError) as err:
        raise InputError(f"entries: model {name!r}, record is not JSON-safe ({err})") from err
    return _Checked(record, arrays)


def _entry_checksum(checked: _Checked, hashers: Mapping[str, Any] | None = None) -> int:
    """A cheap checksum (CRC-32) of one entry, to notice an entry that reads differently twice.

    With ``hashers`` (one SHA-256 per stored array), also feed each array's bytes to its hasher.
    """
    value = zlib.crc32(json.dumps(checked.record, sort_keys=True).encode("utf-8"))
    for name, array in checked.arrays.items():
        data = le_bytes(array)
        if hashers is not None:
            hashers[name].update(data)
        value = zlib.crc32(data, value)
    return value


class _Plan(NamedTuple):
    """What the first pass over the entries learns."""

    n_points: int
    records: list[dict[str, Any]]
    checksums: list[int]
    vertex_offsets: NDArray[np.int64]
    face_offsets: NDArray[np.int64]
    digests: dict[str, str]


def _first_pass(entries: Sequence[ModelEntry], n_views: int, progress: Bar) -> _Plan:
    hashers = {name: hashlib.sha256() for name in _ENTRY_ARRAYS}
    records: list[dict[str, Any]] = []
    checksums: list[int] = []
    n_vertices = [0]
    n_faces = [0]
    seen: set[str] = set()
    previous: tuple[str, str] | None = None
    n_points: int | None = None
    for position in range(len(entries)):
        checked = _check_entry(entries[position], position, n_views, n_points)
        record = checked.record
        key = (record["category"], record["name"])
        if record["name"] in seen:
            raise InputError(f"entries: duplicate model name {record['name']!r}")
        if previous is not None and key < previous:
            raise InputError(
                f"entries: model {record['name']!r} ({key[0]}/{key[1]}) comes after "
                f"{previous[0]}/{previous[1]}; entries must be sorted by (category, name)"
            )
        seen.add(record["name"])
        previous = key
        n_points = checked.arrays["points"].shape[0]
        records.append(record)
        checksums.append(_entry_checksum(checked, hashers))
        n_vertices.append(record["n_vertices"])
        n_faces.append(record["n_faces"])
        progress.update(1)
    return _Plan(
        n_points=0 if n_points is None else n_points,
        records=records,
        checksums=checksums,
        vertex_offsets=np.cumsum(n_vertices, dtype=np.int64),
        face_offsets=np.cumsum(n_faces, dtype=np.int64),
        digests={name: hasher.hexdigest() for name, hasher in hashers.items()},
    )


def _check_views(views: ArrayLike) -> NDArray[np.float64]:
    try:
        array = np.array(views, dtype=np.dtype("<f8"))
    except (TypeError, ValueError) as err:
        raise InputError(f"views: not a numeric array ({err})") from err
    if array.ndim != 2 or array.shape[1] != 3 or array.shape[0] < 1:
        raise InputError(f"views: expected shape (n_views, 3) with n_views >= 1, got {array.shape}")
    if not np.isfinite(array).all():
        raise InputError("views: contains NaN or infinite values")
    if not np.allclose(np.linalg.norm(array, axis=1), 1.0, atol=1e-6):
        raise InputError("views: expected unit vectors")
    return array


def _check_failures(failures: Sequence[Mapping[str, str]]) -> list[dict[str, str]]:
    checked = []
    for position, failure in enumerate(failures):
        if not isinstance(failure, Mapping) or set(failure) != set(FAILURE_KEYS):
            keys = sorted(failure) if isinstance(failure, Mapping) else type(failure).__name__
            raise InputError(
                f"failures[{position}]: expected exactly the keys {list(FAILURE_KEYS)}, got {keys}"
            )
        if not all(isinstance(failure[key], str) for key in FAILURE_KEYS):
            raise InputError(f"failures[{position}]: values must be strings")
        checked.append({key: failure[key] for key in FAILURE_KEYS})
    return checked


def _root_attrs(attrs: Mapping[str, Any], *, n_models: int, n_views: int,
                n_points: int | None, n_failures: int) -> dict[str, Any]:
    """The complete root attributes; ``n_points`` None checks ``attrs`` before it is known."""
    if not isinstance(attrs, Mapping):
        raise InputError(f"attrs: expected a mapping, got {type(attrs).__name__}")
    missing = [key for key in BUILD_ATTRS if key not in attrs]
    if missing:
        raise InputError(f"attrs: missing root attributes {missing}")
    if HDF5_JSON_KEY in attrs:
        raise InputError(f"attrs: {HDF5_JSON_KEY!r} is reserved for HDF5 files")
    own: dict[str, Any] = {
        "format": FORMAT_NAME,
        "schema_version": SCHEMA_VERSION,
        "measures": list(MEASURES),
        "higher_is_better": list(HIGHER_IS_BETTER),
        "n_models": n_models,
        "n_views": n_views,
        "n_points": 0 if n_points is None else n_points,
    }
    tail = {"n_failures": n_failures}
    for key, value in {**own, **tail}.items():
        # Attributes read back from a store may be passed through unchanged.
        if key == "n_points" and n_points is None:
            continue
        if key in attrs and attrs[key] != value:
            raise InputError(
                f"attrs: {key!r} is set by the writer to {value!r}, got {attrs[key]!r}"
            )
    root = dict(own)
    for key in BUILD_ATTRS:
        root[key] = attrs[key]
    for key in sorted(set(attrs) - set(root) - set(tail)):
        if not isinstance(key, str):
            raise InputError(f"attrs: keys must be strings, got {key!r}")
        root[key] = attrs[key]
    root.update(tail)
    try:
        # A JSON round trip turns tuples into lists and rejects NaN and non-JSON types.
        return dict(json.loads(json.dumps(root, allow_nan=False)))
    except (TypeError, ValueError) as err:
        raise InputError(f"attrs: not JSON-safe ({err})") from err


class _Sink(Protocol):
    def create(self, name: str, shape: tuple[int, ...], dtype: np.dtype[Any],
               chunks: tuple[int, ...], sha256: str) -> Any: ...

    def close(self) -> None: ...


class _RowWriter:
    """Appends rows to a stored array, writing whole chunks once each."""

    def __init__(self, array: Any, chunk_rows: int) -> None:
        self._array = array
        self._chunk_rows = max(1, chunk_rows)
        self._pending: list[NDArray[Any]] = []
        self._n_pending = 0
        self._start = 0

    def append(self, rows: NDArray[Any]) -> None:
        if len(rows) == 0:
            return
        self._pending.append(rows)
        self._n_pending += len(rows)
        if self._n_pending >= self._chunk_rows:
            self._flush(whole_chunks_only=True)

    def finish(self) -> None:
        self._flush(whole_chunks_only=False)

    def _flush(self, *, whole_chunks_only: bool) -> None:
        if not self._n_pending:
            return
        block = self._pending[0] if len(self._pending) == 1 else np.concatenate(self._pending)
        n_rows = len(block)
        if whole_chunks_only:
            n_rows -= n_rows % self._chunk_rows
        self._array[self._start : self._start + n_rows] = block[:n_rows]
        self._start += n_rows
        rest = block[n_rows:]
        self._pending = [rest] if len(rest) else []
        self._n_pending = len(rest)


def _temporary_sibling(target: Path, kind: str) -> Path:
    prefix, suffix = temporary_prefix(target.name), ".partial"
    if kind == "zarr":
        return Path(tempfile.mkdtemp(prefix=prefix, suffix=suffix, dir=target.parent))
    handle, name = tempfile.mkstemp(prefix=prefix, suffix=suffix, dir=target.parent)
    os.close(handle)
    return Path(name)


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    elif path.exists() or path.is_symlink():
        path.unlink()


def _move_into_place(temporary: Path, target: Path, kind: str) -> None:
    if kind != "zarr":
        with open(temporary, "rb+") as handle:
            os.fsync(handle.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o666 & ~umask)  # mkstemp made it private (0600)
        os.replace(temporary, target)
        return
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o777 & ~umask)  # mkdtemp made it private (0700)
    if not target.exists():
        os.rename(temporary, target)
        return
    # A directory cannot be renamed over a non-empty one: move the old store aside first.
    previous = temporary.with_name(temporary.name[: -len(".partial")] + ".old")
    os.rename(target, previous)
    try:
        os.rename(temporary, target)
    except OSError:
        os.rename(previous, target)
        raise
    shutil.rmtree(previous, ignore_errors=True)


def write_dataset(
    path: str | os.PathLike[str],
    entries: Sequence[ModelEntry],
    *,
    attrs: Mapping[str, Any],
    views: ArrayLike,
    failures: Sequence[Mapping[str, str]],
    progress: bool = False,
) -> Path:
    """Write a dataset store atomically.

    The container follows the suffix of ``path`` (see :func:`store_kind`).
    The entries are read twice, one at a time, and never all held: a first
    pass checks them and computes sizes and SHA-256 digests, a second writes
    them. Every array is created with its ``sha256`` attribute already set.

    The store is written to a hidden temporary sibling
    (``.<name>.<random>.partial``) and renamed over ``path`` at the end, so an
    error or a crash never leaves a half-written store under ``path``, and an
    existing store there stays intact until the new one is complete. (For a
    ``*.zarr`` directory the old one is moved aside just before the rename.)

    Parameters
    ----------
    path : path-like
        Target ``*.zarr``, ``*.zarr.zip``, ``*.h5`` or ``*.hdf5``; its folder
        must exist. An existing store there is replaced.
    entries : sequence of ModelEntry
        Supports ``len`` and ``[i]`` and may load lazily; each entry is read
        exactly twice. Sorted by ``(category, name)``, names unique, the same
        number of points in every entry and ``len(views)`` rows of quality.
        May be empty: the store then has zero models (and ``n_points`` 0).
    attrs : mapping
        The build's root attributes, all of :data:`BUILD_ATTRS` (other
        JSON-safe keys are kept too). Keys of :data:`WRITER_ATTRS` are set by
        the writer; they may be passed only with the value the writer would
        set (e.g. attributes read back from another store).
    views : (n_views, 3) array_like
        Unit view directions, stored as float64.
    failures : sequence of mapping
        One ``{"source", "category", "reason"}`` dict of strings per input
        that could not be processed.
    progress : bool
        Show a tqdm progress bar on stderr for each pass (default: False).

    Returns
    -------
    path : pathlib.Path
        The written store.

    Raises
    ------
    InputError
        On an unknown suffix, a missing folder, a target of the wrong kind
        (a file where a directory goes or vice versa), or a bad entry,
        attribute, view array or failure record; the message names it.
    VerificationError
        If an entry reads differently the second time.
    """
    target = Path(path)
    kind = store_kind(target)
    if not target.parent.is_dir():
        raise InputError(f"{target}: output folder {target.parent} does not exist")
    if target.exists() and target.is_dir() != (kind == "zarr"):
        expected = "a directory" if kind == "zarr" else "a file"
        raise InputError(f"{target}: exists and is not {expected}")
    view_directions = _check_views(views)
    failure_records = _check_failures(failures)
    n_views = len(view_directions)
    n_models = len(entries)
    _root_attrs(attrs, n_models=n_models, n_views=n_views, n_points=None,
                n_failures=len(failure_records))  # fail before reading any entry

    with progress_bar(total=n_models, description=f"{target.name}: check", unit="model",
                      enabled=progress) as bar:
        plan = _first_pass(entries, n_views, bar)
    root_attrs = _root_attrs(
        attrs, n_models=n_models, n_views=n_views, n_points=plan.n_points,
        n_failures=len(failure_records),
    )
    whole = {
        "views": view_directions,
        "mesh_vertex_offsets": plan.vertex_offsets,
        "mesh_face_offsets": plan.face_offsets,
        "models_json": json_bytes(plan.records),
        "failures_json": json_bytes(failure_records),
    }
    n_points = plan.n_points
    layout: dict[str, tuple[tuple[int, ...], tuple[int, ...]]] = {
        # name: (shape, chunks)
        "views": ((n_views, 3), (n_views, 3)),
        "points": ((n_models, n_points, 3), (1, n_points, 3)),
        "normals": ((n_models, n_points, 3), (1, n_points, 3)),
        "quality": ((n_models, n_views, 4), (_CHUNK_MODELS, n_views, 4)),
        "quality_raw": ((n_models, n_views, 4), (_CHUNK_MODELS, n_views, 4)),
        "best_index": ((n_models, 4), (_CHUNK_MODELS, 4)),
        "best_value": ((n_models, 4), (_CHUNK_MODELS, 4)),
        "worst_index": ((n_models, 4), (_CHUNK_MODELS, 4)),
        "worst_value": ((n_models, 4), (_CHUNK_MODELS, 4)),
        "mesh_vertices": ((int(plan.vertex_offsets[-1]), 3), (_CHUNK_ROWS, 3)),
        "mesh_vertex_offsets": ((n_models + 1,), (_CHUNK_ROWS,)),
        "mesh_faces": ((int(plan.face_offsets[-1]), 3), (_CHUNK_ROWS, 3)),
        "mesh_face_offsets": ((n_models + 1,), (_CHUNK_ROWS,)),
        "models_json": ((len(whole["models_json"]),), (_CHUNK_BYTES,)),
        "failures_json": ((len(whole["failures_json"]),), (_CHUNK_BYTES,)),
    }
    digests = {name: array_sha256(array) for name, array in whole.items()}
    digests.update(plan.digests)

    temporary = _temporary_sibling(target, kind)
    is_done = False
    try:
        if kind == "hdf5":
            from vptoolkit.dataset._hdf5 import Hdf5Sink

            sink: _Sink = Hdf5Sink(temporary, root_attrs)
        else:
            from vptoolkit.dataset._zarr import ZarrSink

            sink = ZarrSink(_require_zarr(), temporary, kind, root_attrs)
        try:
            stored = {}
            for name in ARRAY_NAMES:
                shape, chunks = layout[name]
                dtype = (
                    whole[name].dtype if name in whole else _ENTRY_ARRAYS[name][1]
                )
                stored[name] = sink.create(name, shape, np.dtype(dtype), chunks, digests[name])
            for name, array in whole.items():
                if array.size:
                    stored[name][...] = array
            _second_pass(entries, plan, stored, layout, target.name, progress)
        finally:
            sink.close()
        _move_into_place(temporary, target, kind)
        remove_stale_partials(target.parent, target.name)  # left by a killed earlier write
        is_done = True
    finally:
        if not is_done:
            _remove(temporary)
    return target


def _second_pass(entries: Sequence[ModelEntry], plan: _Plan, stored: dict[str, Any],
                 layout: dict[str, tuple[tuple[int, ...], tuple[int, ...]]],
                 label: str, progress: bool) -> None:
    writers = {name: _RowWriter(stored[name], layout[name][1][0]) for name in _ENTRY_ARRAYS}
    n_views = layout["views"][0][0]
    with progress_bar(total=len(plan.records), description=f"{label}: write", unit="model",
                      enabled=progress) as bar:
        for position, record in enumerate(plan.records):
            checked = _check_entry(entries[position], position, n_views, plan.n_points or None)
            if _entry_checksum(checked) != plan.checksums[position]:
                raise VerificationError(
                    f"entries: model {record['name']!r} read differently on the second pass; "
                    "entries must be deterministic"
                )
            for name, array in checked.arrays.items():
                writers[name].append(array[None] if name not in ("mesh_vertices", "mesh_faces")
                                     else array)
            bar.update(1)
    for writer in writers.values():
        writer.finish()


# --------------------------------------------------------------------------- reading


class StoreReader:
    """Read access to one dataset store; returned by :func:`open_store`.

    Arrays are read lazily: :meth:`array` returns a ``zarr.Array`` or
    ``h5py.Dataset`` whose slices are numpy arrays. Use the reader as a
    context manager or call :meth:`close`.

    Attributes
    ----------
    path : pathlib.Path
        The store.
    kind : str
        ``"zarr"``, ``"zarr-zip"`` or ``"hdf5"``.
    attrs : dict
        Root attributes as JSON types (HDF5's JSON-encoded ones decoded).
    """

    def __init__(self, path: Path, kind: str, root: Any, store: Any,
                 attrs: dict[str, Any], array_names: list[str]) -> None:
        self.path = path
        self.kind = kind
        self.attrs = attrs
        self._root = root
        self._store = store
        self._array_names = array_names
        self._arrays: dict[str, Any] = {}
        self._models: list[dict[str, Any]] | None = None
        self._is_closed = False

    def __repr__(self) -> str:
        return f"StoreReader({str(self.path)!r}, kind={self.kind!r})"

    def __enter__(self) -> StoreReader:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    @property
    def n_models(self) -> int:
        """Number of models ``M``."""
        return int(self.attrs["n_models"])

    def array_names(self) -> list[str]:
        """Names of the root arrays, sorted."""
        return list(self._array_names)

    def array(self, name: str) -> Any:
        """One root array, lazily.

        Returns
        -------
        array : zarr.Array or h5py.Dataset
            Has ``shape`` and ``dtype``; slicing returns numpy arrays.

        Raises
        ------
        InputError
            If the reader is closed or the store has no such array.
        """
        if self._is_closed:
            raise InputError(f"{self.path.name}: store is closed")
        if name not in self._arrays:
            if name not in self._array_names:
                raise InputError(f"{self.path.name}: no array {name!r}")
            self._arrays[name] = self._root[name]
        return self._arrays[name]

    def stored_sha256(self, name: str) -> str:
        """The ``sha256`` attribute of an array (see :func:`array_sha256`).

        Raises
        ------
        InputError
            If the array or its attribute is missing.
        """
        attributes = self.array(name).attrs
        if "sha256" not in attributes:
            raise InputError(f"{self.path.name}: array {name!r} has no sha256 attribute")
        value = attributes["sha256"]
        return value.decode("ascii") if isinstance(value, bytes) else str(value)

    def models(self) -> list[dict[str, Any]]:
        """The decoded ``models_json``: one record per model, in row order."""
        if self._models is None:
            decoded = self._decode("models_json")
            if not isinstance(decoded, list) or len(decoded) != self.n_models:
                raise InputError(
                    f"{self.path.name}: models_json does not hold {self.n_models} records"
                )
            self._models = decoded
        return [dict(record) for record in self._models]

    def failures(self) -> list[dict[str, Any]]:
        """The decoded ``failures_json``: one record per failed input."""
        decoded = self._decode("failures_json")
        if not isinstance(decoded, list):
            raise InputError(f"{self.path.name}: failures_json is not a list")
        return decoded

    def entry(self, index: int) -> ModelEntry:
        """Read model ``index`` (negative counts from the end) in full.

        Returns
        -------
        entry : ModelEntry
            Arrays in the stored dtypes.

        Raises
        ------
        IndexError
            If ``index`` is out of range.
        """
        n_models = self.n_models
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise InputError(f"index: expected an integer, got {index!r}")
        if not -n_models <= index < n_models:
            raise IndexError(f"index {index} out of range for {n_models} models")
        row = int(index) % n_models
        record = self.models()[row]
        vertex_offsets = self.array("mesh_vertex_offsets")[row : row + 2]
        face_offsets = self.array("mesh_face_offsets")[row : row + 2]
        return ModelEntry(
            name=record["name"],
            category=record["category"],
            split=record["split"],
            source=record["source"],
            source_sha256=record["source_sha256"],
            points=np.asarray(self.array("points")[row]),
            normals=np.asarray(self.array("normals")[row]),
            quality=np.asarray(self.array("quality")[row]),
            quality_raw=np.asarray(self.array("quality_raw")[row]),
            best_index=np.asarray(self.array("best_index")[row]),
            best_value=np.asarray(self.array("best_value")[row]),
            worst_index=np.asarray(self.array("worst_index")[row]),
            worst_value=np.asarray(self.array("worst_value")[row]),
            vertices=np.asarray(self.array("mesh_vertices")[vertex_offsets[0] : vertex_offsets[1]]),
            faces=np.asarray(self.array("mesh_faces")[face_offsets[0] : face_offsets[1]]),
            cleaning=record["cleaning"],
            view_set=record.get("view_set"),
        )

    def close(self) -> None:
        """Close the underlying file; safe to call twice."""
        if self._is_closed:
            return
        self._is_closed = True
        self._arrays.clear()
        self._store.close()

    def _decode(self, name: str) -> Any:
        try:
            return from_json_bytes(self.array(name)[...])
        except InputError as err:
            raise InputError(f"{self.path.name}: {name} is not UTF-8 JSON") from err


def zarr_is_usable() -> bool:
    """Whether zarr >= 3 (which reads Zarr v3 stores) is installed, without importing it."""
    if not is_available("zarr"):
        return False
    try:
        major = importlib.metadata.version("zarr").split(".")[0]
    except importlib.metadata.PackageNotFoundError:
        return False
    return major.isdigit() and int(major) >= 3


def _require_zarr() -> Any:
    """zarr >= 3, or a MissingDependencyError saying what to install instead."""
    zarr = require("zarr", extra="dataset")
    version = str(getattr(zarr, "__version__", "0"))
    major = version.split(".")[0]
    if not (major.isdigit() and int(major) >= 3):
        raise MissingDependencyError(
            f"zarr {version}: Zarr v3 stores need zarr>=3 (Python >= 3.11); install it with "
            "pip install 'zarr>=3', or read the release's .h5 file with h5py"
        )
    return zarr


def open_store(path: str | os.PathLike[str], *, check_chunks: bool = True) -> StoreReader:
    """Open a dataset store for reading.

    Parameters
    ----------
    path : path-like
        A ``*.zarr`` directory, a ``*.zarr.zip`` file or an ``*.h5`` /
        ``*.hdf5`` file (use :func:`find_store` for folders).
    check_chunks : bool
        Refuse a Zarr store with a missing chunk, which would read as zeros
        (default: True; :func:`vptoolkit.dataset.manifest.verify` turns it
        off to report every damaged array itself).

    Returns
    -------
    reader : StoreReader

    Raises
    ------
    InputError
        If the file is missing, unreadable, not a vptoolkit viewpoint
        dataset, lacks one of :data:`ARRAY_NAMES`, or has a
        ``schema_version`` other than :data:`SCHEMA_VERSION`.
    VerificationError
        If its ``measures`` or ``higher_is_better`` attribute differs from
        :data:`~vptoolkit.conventions.MEASURES` and
        :data:`~vptoolkit.conventions.HIGHER_IS_BETTER`, or (with
        ``check_chunks``) a chunk is missing; the message names the array and
        its models.
    """
    source = Path(path)
    kind = store_kind(source)
    if not source.exists():
        raise InputError(f"{source}: no such file or directory")
    if source.is_dir() != (kind == "zarr"):
        raise InputError(f"{source}: expected a {'directory' if kind == 'zarr' else 'file'}")
    try:
        if kind == "hdf5":
            from vptoolkit.dataset._hdf5 import open_hdf5

            root, store, attrs, names = open_hdf5(source)
        else:
            from vptoolkit.dataset._zarr import open_zarr

            root, store, attrs, names = open_zarr(_require_zarr(), source, kind)
    except (OSError, ValueError, KeyError, TypeError, zipfile.BadZipFile) as err:
        raise InputError(f"{source}: not a readable dataset store ({err})") from err
    reader = StoreReader(source, kind, root, store, attrs, names)
    is_valid = False
    try:
        _check_root(reader)
        if check_chunks:
            from vptoolkit.dataset._zarr import check_chunks as _check_chunks

            _check_chunks(reader)
        is_valid = True
    finally:
        if not is_valid:
            reader.close()
    return reader


def _check_root(reader: StoreReader) -> None:
    attrs, label = reader.attrs, reader.path.name
    if attrs.get("format") != FORMAT_NAME:
        raise InputError(
            f"{label}: not a vptoolkit viewpoint dataset (format {attrs.get('format')!r})"
        )
    version = attrs.get("schema_version")
    if version != SCHEMA_VERSION:
        raise InputError(
            f"{label}: schema_version {version!r} is not supported (this vptoolkit reads "
            f"{SCHEMA_VERSION})"
        )
    if attrs.get("measures") != list(MEASURES):
        raise VerificationError(
            f"{label}: measures {attrs.get('measures')!r} differ from {list(MEASURES)}"
        )
    if attrs.get("higher_is_better") != list(HIGHER_IS_BETTER):
        raise VerificationError(
            f"{label}: higher_is_better {attrs.get('higher_is_better')!r} differs from "
            f"{list(HIGHER_IS_BETTER)}"
        )
    missing = [name for name in ARRAY_NAMES if name not in reader.array_names()]
    if missing:
        raise InputError(f"{label}: missing arrays {missing}")
    for key in ("n_models", "n_views", "n_points"):
        if not isinstance(attrs.get(key), int):
            raise InputError(f"{label}: root attribute {key!r} is missing or not an integer")
