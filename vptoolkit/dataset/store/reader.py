"""Reading a dataset store: :func:`open_store` and :class:`StoreReader`.

:func:`open_store` opens any container (the container's own code is in
:mod:`vptoolkit.dataset.store._zarr` and :mod:`vptoolkit.dataset.store._hdf5`), checks
the root (format, schema version, the measures and their directions, arrays, counts) and, for
Zarr, that no chunk is missing; :class:`StoreReader` then reads arrays
lazily, a model (:meth:`StoreReader.entry`) or every model as a lazy
sequence (:meth:`StoreReader.entries`) by the declarations of
:data:`~vptoolkit.dataset.store.schema.ARRAY_SPECS`, and decodes the JSON
records.
"""

from __future__ import annotations

import io
import os
import weakref
import zipfile
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import one_line
from vptoolkit.dataset.store.containers import require_zarr, store_kind
from vptoolkit.dataset.store.entries import LazyEntries
from vptoolkit.dataset.store.schema import (
    ARRAY_NAMES,
    ARRAY_SPECS,
    ENTRY_ARRAYS,
    FORMAT_NAME,
    SCHEMA_VERSION,
    STRING_ARRAYS,
    ModelEntry,
    class_labels,
    class_names,
    from_json_bytes,
    registered_measures,
)
from vptoolkit.errors import InputError, VerificationError, VptoolkitError
from vptoolkit.files import check_path_part

__all__ = ["StoreReader", "open_store"]

_MAX_NAMED_MODELS = 3  # models named in an error message before "and N more"


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

    @property
    def measures(self) -> tuple[str, ...]:
        """The names of the columns of every measure axis (``quality`` is ``(M, V, K)`` for
        ``K`` names): the root attribute ``measures``, by default
        :data:`~vptoolkit.measures.registry.PAPER_MEASURES`."""
        return tuple(self.attrs["measures"])

    @property
    def higher_is_better(self) -> tuple[bool, ...]:
        """For each of :attr:`measures`, whether a higher raw value is better, from the
        registry.

        Raises
        ------
        InputError
            One line, for a measure the registry does not know
            (:func:`~vptoolkit.dataset.store.schema.registered_measures`).
        """
        return tuple(m.higher_is_better
                     for m in registered_measures(self.measures, self.path.name))

    def array_names(self) -> list[str]:
        """Names of the root arrays, sorted."""
        return list(self._array_names)

    def array(self, name: str) -> Any:
        """One root array, lazily.

        Returns
        -------
        array : zarr.Array or h5py.Dataset
            Wrapped so that a slice that cannot be decoded (a damaged chunk)
            raises a :class:`VerificationError` naming the store, the array
            and its models; attributes (``shape``, ``dtype``, ``attrs``, ...)
            are the wrapped array's.

        Raises
        ------
        InputError
            If the reader is closed or the store has no such array.
        VerificationError
            If the array's header cannot be read (a damaged HDF5 store).
        """
        if self._is_closed:
            raise InputError(f"{self.path.name}: store is closed")
        if name not in self._arrays:
            if name not in self._array_names:
                raise InputError(f"{self.path.name}: no array {name!r}")
            try:
                node = self._root[name]
            except (RuntimeError, OSError, KeyError, ValueError) as err:  # a damaged header
                raise VerificationError(
                    f"{self.path.name}: array {name!r} cannot be opened ({one_line(err)}); "
                    "the store is damaged (run vptool verify)") from err
            self._arrays[name] = _CheckedArray(self, name, node)
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
        """The decoded ``models_json``: one record per model, in row order.

        Raises
        ------
        InputError
            If ``models_json`` does not hold one record per model, or a
            record's name or category cannot be a file or folder name
            (:func:`~vptoolkit.files.check_path_part`; names become output
            paths, so a store written elsewhere or before the rule is refused
            here).
        """
        return [dict(record) for record in self._records()]

    def _records(self) -> list[dict[str, Any]]:
        """The checked records of :meth:`models`, decoded once and not copied."""
        if self._models is None:
            decoded = self._decode("models_json")
            if not isinstance(decoded, list) or len(decoded) != self.n_models or not all(
                    isinstance(record, dict) for record in decoded):
                raise InputError(
                    f"{self.path.name}: models_json does not hold {self.n_models} records"
                )
            for record in decoded:
                name = check_path_part(record.get("name"), f"{self.path.name}: model name")
                check_path_part(record.get("category"),
                                f"{self.path.name}: model {name!r}, category")
            self._models = decoded
        return self._models

    def class_labels(self) -> tuple[list[str], NDArray[np.int64]]:
        """The class names and each model's class label.

        Returns
        -------
        names : list of str
            The root attribute ``class_names``, checked against the models'
            categories; for a store without it, the sorted categories.
        labels : (n_models,) int64
            The stored ``labels`` array, in row order; worked out from the
            records' categories (:func:`~vptoolkit.dataset.store.schema.class_labels`)
            for a store without one.

        Raises
        ------
        InputError
            If ``class_names`` lacks a category or is not sorted and unique,
            or ``labels`` does not hold one label of ``names`` per model.
        """
        categories = [str(record["category"]) for record in self.models()]
        given = self.attrs.get("class_names")
        if "labels" not in self.array_names():
            return class_labels(categories, given)
        names = class_names(categories, given)
        labels = np.asarray(self.array("labels")[...], dtype=np.int64)
        if labels.shape != (self.n_models,) or not np.all((labels >= 0) & (labels < len(names))):
            raise InputError(f"{self.path.name}: labels does not hold a class label (0 to "
                             f"{len(names) - 1}) per model")
        return names, labels

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
        record = self._records()[row]
        arrays: dict[str, NDArray[Any]] = {}
        for spec in ENTRY_ARRAYS:
            stored = self.array(spec.name)
            if spec.per == "mesh":
                first, stop = self.array(spec.offsets)[row : row + 2]
                arrays[spec.field] = np.asarray(stored[first:stop])
            else:
                arrays[spec.field] = np.asarray(stored[row])
        return ModelEntry(
            name=record["name"],
            category=record["category"],
            split=record["split"],
            source=record["source"],
            source_sha256=record["source_sha256"],
            cleaning=record["cleaning"],
            view_set=record.get("view_set"),
            **arrays,
        )

    def entries(self) -> LazyEntries:
        """The models as a lazy sequence: item ``i`` is :meth:`entry` ``(i)``, read on access.

        Returns
        -------
        entries : LazyEntries
            ``n_models`` entries, none held: e.g. to write the store again
            elsewhere with :func:`~vptoolkit.dataset.store.writer.write_dataset`,
            one model in memory at a time.
        """
        return LazyEntries(self.n_models, self.entry)

    def models_of_rows(self, name: str, first: int, stop: int) -> str:
        """Which models rows ``first:stop`` of an array belong to, for an error message.

        Returns
        -------
        text : str
            ``"models a, b, c and 4 more"``, ``"no model"``, ``"which every model
            uses"`` (an array not split by model) or, when ``models_json`` is
            unreadable, ``"models unknown (models_json unreadable)"``.
        """
        try:
            names = [str(record.get("name")) for record in self.models()]
            spec = ARRAY_SPECS.get(name)
            if spec is not None and spec.per == "model":
                rows = list(range(first, min(stop, len(names))))
            elif spec is not None and spec.per == "mesh":
                offsets = np.asarray(self._root[spec.offsets][...])
                rows = [
                    row for row in range(len(names))
                    if offsets[row] < stop and offsets[row + 1] > first
                ]
            else:
                return "which every model uses"
        except Exception:  # noqa: BLE001 - only a message is being built
            return "models unknown (models_json unreadable)"
        shown = ", ".join(names[row] for row in rows[:_MAX_NAMED_MODELS])
        hidden = len(rows) - _MAX_NAMED_MODELS
        extra = f" and {hidden} more" if hidden > 0 else ""
        return f"models {shown}{extra}" if rows else "no model"

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


class _CheckedArray:
    """A stored array whose reads turn a decoding failure into one line.

    zarr raises blosc's ``RuntimeError`` (or a codec's ``ValueError``) and
    h5py an ``OSError`` for a chunk that does not decompress; this names the
    store, the array and the models of the rows read instead.
    """

    def __init__(self, reader: StoreReader, name: str, array: Any) -> None:
        self._reader = reader
        self._name = name
        self._array = array

    def __getattr__(self, attribute: str) -> Any:
        if attribute in ("_reader", "_name", "_array"):  # not set yet (copy, unpickling)
            raise AttributeError(attribute)
        return getattr(self._array, attribute)

    def __len__(self) -> int:
        return len(self._array)

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        values = np.asarray(self[...])
        return values if dtype is None else values.astype(dtype)

    def __getitem__(self, key: Any) -> Any:
        try:
            return self._array[key]
        except VptoolkitError:
            raise
        except (RuntimeError, ValueError, OSError) as err:
            first, stop = _rows_of(key, int(self._array.shape[0]) if self._array.shape else 0)
            models = self._reader.models_of_rows(self._name, first, stop)
            raise VerificationError(
                f"{self._reader.path.name}: array {self._name!r} cannot be decoded, {models} "
                f"({one_line(err)}); the store is damaged (run vptool verify)"
            ) from err


def _rows_of(key: Any, n_rows: int) -> tuple[int, int]:
    """The rows ``first:stop`` a selection reads (all unless it starts with an int or slice)."""
    head = key[0] if isinstance(key, tuple) and key else key
    if isinstance(head, (int, np.integer)) and not isinstance(head, bool):
        row = int(head) % n_rows if n_rows else 0
        return row, row + 1
    if isinstance(head, slice):
        first, stop, _ = head.indices(n_rows)
        return first, stop
    return 0, n_rows


def open_store(path: str | os.PathLike[str], *, check_chunks: bool = True,
               stream: BinaryIO | io.RawIOBase | None = None) -> StoreReader:
    """Open a dataset store for reading.

    Parameters
    ----------
    path : path-like
        A ``*.zarr`` directory, a ``*.zarr.zip`` file or an ``*.h5`` /
        ``*.hdf5`` file (use :func:`find_store` for folders).
    check_chunks : bool
        Refuse a Zarr store with a missing chunk, which would read as zeros
        (default: True; :func:`vptoolkit.dataset.release.manifest.verify` turns it
        off to report every damaged array itself).
    stream : binary file, optional
        A readable, seekable file holding the HDF5 store ``path`` names, read
        instead of ``path`` (which need not exist): an archive read by byte
        ranges (:class:`vptoolkit.data.ranges.RangeFile`). The reader closes
        the HDF5 file, not the stream; close the reader first, then the stream.

    Returns
    -------
    reader : StoreReader

    Raises
    ------
    InputError
        If the file is missing, unreadable, not a vptoolkit viewpoint
        dataset, lacks one of :data:`ARRAY_NAMES` (a store without the root
        attribute ``class_names`` may lack the label and string arrays), or has a
        ``schema_version`` other than :data:`SCHEMA_VERSION`.
    VerificationError
        If its ``measures`` attribute is not a list of distinct names, its
        ``higher_is_better`` not one bool per name or, for a measure the
        registry knows, not the registry's direction, a measure array's last
        axis does not hold one column per name, or (with ``check_chunks``) a
        chunk is missing; the message names the array and its models.

    Notes
    -----
    A measure the registry does not know (a store written by another version)
    opens all the same: its arrays are there. What needs its direction or title
    (:attr:`StoreReader.higher_is_better`, the card) says so in one line.
    """
    source = Path(path)
    kind = store_kind(source)
    if stream is not None and kind != "hdf5":
        raise InputError(f"{source}: only an HDF5 store is read from a stream")
    if stream is None and not source.exists():
        raise InputError(f"{source}: no such file or directory")
    if stream is None and source.is_dir() != (kind == "zarr"):
        raise InputError(f"{source}: expected a {'directory' if kind == 'zarr' else 'file'}")
    try:
        if kind == "hdf5":
            from vptoolkit.dataset.store._hdf5 import open_hdf5

            root, store, attrs, names = open_hdf5(source, stream)
        else:
            from vptoolkit.dataset.store._zarr import open_zarr

            root, store, attrs, names = open_zarr(require_zarr(), source, kind)
    except VptoolkitError:  # the stream's own one-line error (a URL that answered wrongly)
        raise
    except (OSError, ValueError, KeyError, TypeError, zipfile.BadZipFile) as err:
        raise InputError(f"{source}: not a readable dataset store ({err})") from err
    reader = StoreReader(source, kind, root, store, attrs, names)
    if stream is not None:  # h5py crashes at exit over a Python file still open: close it first
        weakref.finalize(reader, store.close)
    is_valid = False
    try:
        _check_root(reader)
        if check_chunks:
            from vptoolkit.dataset.store._zarr import check_chunks as _check_chunks

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
    _check_measures(attrs, label)
    # A store without class_names predates the label and string arrays; it is read without them.
    expected = ARRAY_NAMES if "class_names" in attrs else [
        name for name in ARRAY_NAMES if name not in (*STRING_ARRAYS, "labels")]
    missing = [name for name in expected if name not in reader.array_names()]
    if missing:
        raise InputError(f"{label}: missing arrays {missing}")
    for key in ("n_models", "n_views", "n_points"):
        if not isinstance(attrs.get(key), int):
            raise InputError(f"{label}: root attribute {key!r} is missing or not an integer")
    n_measures = len(attrs["measures"])
    for spec in ENTRY_ARRAYS:
        shape = reader.array(spec.name).shape
        if "n_measures" in spec.shape and (not shape or shape[-1] != n_measures):
            raise VerificationError(
                f"{label}: array {spec.name!r} of shape {tuple(shape)} does not hold one column "
                f"per measure of {attrs['measures']}")


def _check_measures(attrs: dict[str, Any], label: str) -> None:
    """The ``measures`` and ``higher_is_better`` attributes: distinct names, one bool each,
    the registry's direction for every name it knows."""
    from vptoolkit.measures.registry import all_measures

    names, higher = attrs.get("measures"), attrs.get("higher_is_better")
    if not (isinstance(names, list) and names
            and all(isinstance(name, str) and name for name in names)
            and len(set(names)) == len(names)):
        raise VerificationError(f"{label}: measures {names!r} is not a list of distinct names")
    if not (isinstance(higher, list) and len(higher) == len(names)
            and all(isinstance(flag, bool) for flag in higher)):
        raise VerificationError(f"{label}: higher_is_better {higher!r} does not give one "
                                f"direction per measure of {names}")
    known = all_measures()
    for name, flag in zip(names, higher):
        if name in known and known[name].higher_is_better != flag:
            raise VerificationError(
                f"{label}: measures {names} with higher_is_better {higher}: {name} is "
                f"{'higher' if known[name].higher_is_better else 'lower'} is better")
