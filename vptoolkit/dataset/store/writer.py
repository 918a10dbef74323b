"""Writing a dataset store: :func:`write_dataset`.

Two passes over the entries, so a store of any size is written with one
model in memory at a time: the first checks every entry (dtypes, shapes,
sorted unique names and categories that can be file names, finite values,
unit normals), learns the layout and computes each
array's SHA-256; the second writes the rows in chunks and checks that every
entry reads the same as on the first pass. The store is written next to its
target under a temporary name and moved into place at the end, so a reader
never sees a part. Each array's dtype, shape and chunks come from its
declaration in :data:`~vptoolkit.dataset.store.schema.ARRAY_SPECS`. The
containers' own code lives in :mod:`vptoolkit.dataset.store._zarr` and
:mod:`vptoolkit.dataset.store._hdf5`.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import tempfile
import zlib
from collections.abc import Mapping, Sequence
from contextlib import nullcontext
from pathlib import Path
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.conventions import SPLITS
from vptoolkit.dataset.store.containers import require_zarr, store_kind
from vptoolkit.dataset.store.schema import (
    ARRAY_SPECS,
    BUILD_ATTRS,
    ENTRY_ARRAYS,
    FAILURE_KEYS,
    FORMAT_NAME,
    HDF5_JSON_KEY,
    SCHEMA_VERSION,
    ArraySpec,
    ModelEntry,
    array_sha256,
    class_labels,
    json_bytes,
    le_bytes,
    normal_length_problem,
    published_split,
    registered_measures,
)
from vptoolkit.errors import InputError, VerificationError
from vptoolkit.files import (
    check_path_part,
    errors_named,
    held,
    remove_stale_partials,
    temporary_prefix,
)
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.progress import Bar, progress_bar

__all__ = ["write_dataset"]

_SHA256_HEX = re.compile(r"[0-9a-f]{64}")


class _Checked(NamedTuple):
    """One entry's arrays cast to the stored dtypes, in the order they are written."""

    record: dict[str, Any]
    arrays: dict[str, NDArray[Any]]


def _cast(entry_name: str, spec: ArraySpec, value: Any,
          sizes: Mapping[str, int | None]) -> NDArray[Any]:
    """A model's value of an array of :data:`ENTRY_ARRAYS`, checked against its declared
    shape (:meth:`ArraySpec.resolve` of ``sizes``; None accepts any length) and cast to its
    stored dtype."""
    where = f"entries: model {entry_name!r}, {spec.field}"
    dtype, shape = spec.numpy_dtype, spec.resolve(sizes)
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


def _check_entry(entry: Any, position: int, n_views: int, n_points: int | None,
                 n_measures: int, store: str) -> _Checked:
    """Validate one entry and cast its arrays; ``n_points`` None accepts any count.

    ``store`` (the target's name) starts the message about a name or category
    that cannot be a file or folder name (:func:`check_path_part`).
    """
    if not isinstance(entry, ModelEntry):
        raise InputError(f"entries[{position}]: expected a ModelEntry, got {type(entry).__name__}")
    for field in ("name", "category", "split", "source", "source_sha256"):
        value = getattr(entry, field)
        if not isinstance(value, str) or not value:
            raise InputError(
                f"entries[{position}]: {field} must be a non-empty string, got {value!r}"
            )
    name = check_path_part(entry.name, f"{store}: model name")
    check_path_part(entry.category, f"{store}: model {name!r}, category")
    if published_split(entry.split) not in SPLITS:
        raise InputError(f"entries: model {name!r}, split {entry.split!r} is not one of {SPLITS}")
    if not _SHA256_HEX.fullmatch(entry.source_sha256):
        raise InputError(f"entries: model {name!r}, source_sha256 is not 64 lower-case hex digits")
    arrays: dict[str, NDArray[Any]] = {}
    for spec in ENTRY_ARRAYS:
        arrays[spec.name] = _cast(name, spec, getattr(entry, spec.field),
                                  {"n_points": n_points, "n_views": n_views,
                                   "n_measures": n_measures})
        if spec.name == "points":  # declared first: the normals must match its count
            n_points = arrays["points"].shape[0]
            if n_points < 1:
                raise InputError(f"entries: model {name!r}, points is empty")
    for field in ("points", "normals", "mesh_vertices"):
        if not np.isfinite(arrays[field]).all():
            raise InputError(f"entries: model {name!r}, {field} has NaN or infinite values")
    problem = normal_length_problem(arrays["normals"])
    if problem is not None:
        raise InputError(f"entries: model {name!r}, {problem}")
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
        data = le_bytes(array).data
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


def _first_pass(entries: Sequence[ModelEntry], n_views: int, n_measures: int, progress: Bar,
                store: str) -> _Plan:
    hashers = {spec.name: hashlib.sha256() for spec in ENTRY_ARRAYS}
    records: list[dict[str, Any]] = []
    checksums: list[int] = []
    n_vertices = [0]
    n_faces = [0]
    seen: set[str] = set()
    previous: tuple[str, str] | None = None
    n_points: int | None = None
    for position in range(len(entries)):
        checked = _check_entry(entries[position], position, n_views, n_points, n_measures,
                               store)
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


def _strings(values: Any) -> NDArray[np.object_]:
    """A string array (:data:`STRING_ARRAYS`) as the sinks take it: ``str`` objects."""
    return np.array(list(values) or [], dtype=object)


def _measure_names(attrs: Mapping[str, Any]) -> list[str]:
    """The ``measures`` attribute the store gets: ``attrs["measures"]``, registered and
    distinct names (:func:`~vptoolkit.measures.registry.resolve_measures`), or the paper's
    four."""
    from vptoolkit.measures.registry import resolve_measures

    given = attrs.get("measures", PAPER_MEASURES)
    if isinstance(given, str) or not isinstance(given, Sequence) or not given:
        raise InputError(f"attrs: measures must be a non-empty list of names, got {given!r}")
    try:
        return list(resolve_measures([str(name) for name in given]))
    except InputError as err:
        raise InputError(f"attrs: measures: {str(err).removeprefix('measures: ')}") from err


def _root_attrs(attrs: Mapping[str, Any], *, n_models: int, n_views: int,
                n_points: int | None, n_failures: int,
                labels: list[str] | None = None) -> dict[str, Any]:
    """The complete root attributes; ``n_points`` None checks ``attrs`` before it is known.

    ``labels`` is the ``class_names`` attribute, known after the first pass.
    """
    if not isinstance(attrs, Mapping):
        raise InputError(f"attrs: expected a mapping, got {type(attrs).__name__}")
    missing = [key for key in BUILD_ATTRS if key not in attrs]
    if missing:
        raise InputError(f"attrs: missing root attributes {missing}")
    if HDF5_JSON_KEY in attrs:
        raise InputError(f"attrs: {HDF5_JSON_KEY!r} is reserved for HDF5 files")
    names = _measure_names(attrs)
    own: dict[str, Any] = {
        "format": FORMAT_NAME,
        "schema_version": SCHEMA_VERSION,
        "measures": names,
        "higher_is_better": [m.higher_is_better
                             for m in registered_measures(names, "attrs: measures")],
        "n_models": n_models,
        "n_views": n_views,
        "n_points": 0 if n_points is None else n_points,
    }
    tail: dict[str, Any] = {"n_failures": n_failures}
    if labels is not None:
        tail["class_names"] = labels
    for key, value in {**own, **tail}.items():
        # Attributes read back from a store may be passed through unchanged.
        if key == "measures" or (key == "n_points" and n_points is None):
            continue
        if key in attrs and attrs[key] != value:
            raise InputError(
                f"attrs: {key!r} is set by the writer to {value!r}, got {attrs[key]!r}"
            )
    root = dict(own)
    for key in BUILD_ATTRS:
        root[key] = attrs[key]
    for key in sorted(set(attrs) - set(root) - set(tail) - {"class_names"}):
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


def _layout(spec: ArraySpec, whole: Mapping[str, NDArray[Any]],
            sizes: Mapping[str, int]) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """The shape and chunks of a stored array (SCHEMA.md, "Arrays" and "Chunking").

    ``whole`` holds the arrays written at once (a ``"root"`` one's shape is
    its own, a mesh array's rows end at its offsets' last), ``sizes`` the
    ``n_models``, ``n_points``, ``n_views`` and ``n_measures`` of the store. A chunk holds
    ``spec.chunk_rows`` rows along the first axis, or all of them, and the
    whole of every other axis.
    """
    if spec.per == "root":
        shape = tuple(whole[spec.name].shape)
    else:
        declared = spec.resolve(sizes)
        rows = sizes["n_models"] if spec.per == "model" else int(whole[spec.offsets][-1])
        inner = declared if spec.per == "model" else declared[1:]
        shape = (rows, *[int(axis) for axis in inner if axis is not None])  # all sizes known
    return shape, (spec.chunk_rows or shape[0], *shape[1:])


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
        exactly twice. Sorted by ``(category, name)``, names unique, names
        and categories usable as file names (:func:`~vptoolkit.files.check_path_part`),
        normals of unit length (within
        :data:`~vptoolkit.dataset.store.schema.NORMAL_TOLERANCE`), the same
        number of points in every entry and ``len(views)`` rows of quality.
        May be empty: the store then has zero models (and ``n_points`` 0).
    attrs : mapping
        The build's root attributes, all of :data:`BUILD_ATTRS` (other
        JSON-safe keys are kept too), and optionally ``measures``: the
        registered, distinct names of the columns of every entry's measure
        arrays (``quality`` is ``(n_views, K)`` for ``K`` names; default the
        paper's four, :data:`~vptoolkit.measures.registry.PAPER_MEASURES`). The other keys
        of :data:`WRITER_ATTRS` are set by the writer (``higher_is_better``
        from the registry for those names); they may be passed only with the
        value the writer would set (e.g. attributes read back from another
        store).
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
        attribute (an unknown or repeated measure name among them), view array
        or failure record; the message names it.
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
    checked_attrs = _root_attrs(attrs, n_models=n_models, n_views=n_views, n_points=None,
                                n_failures=len(failure_records))  # fail before reading any entry
    n_measures = len(checked_attrs["measures"])

    with progress_bar(total=n_models, description=f"{target.name}: check", unit="model",
                      enabled=progress) as bar:
        plan = _first_pass(entries, n_views, n_measures, bar, str(target))
    categories = [record["category"] for record in plan.records]
    names, labels = class_labels(categories, attrs.get("class_names"))
    root_attrs = _root_attrs(
        attrs, n_models=n_models, n_views=n_views, n_points=plan.n_points,
        n_failures=len(failure_records), labels=names,
    )
    whole: dict[str, NDArray[Any]] = {
        "views": view_directions,
        "mesh_vertex_offsets": plan.vertex_offsets,
        "mesh_face_offsets": plan.face_offsets,
        "models_json": json_bytes(plan.records),
        "failures_json": json_bytes(failure_records),
        "names": _strings(record["name"] for record in plan.records),
        "categories": _strings(categories),
        "splits": _strings(published_split(record["split"]) for record in plan.records),
        "labels": labels,
    }
    sizes = {"n_models": n_models, "n_points": plan.n_points, "n_views": n_views,
             "n_measures": n_measures}
    layout = {name: _layout(spec, whole, sizes) for name, spec in ARRAY_SPECS.items()}
    digests = {name: array_sha256(array) for name, array in whole.items()}
    digests.update(plan.digests)

    temporary = _temporary_sibling(target, kind)
    is_done = False
    try:
        # a full disk or a file too large names the store, not the hidden temporary
        with errors_named(temporary, target):
            # Held, so that a concurrent write's cleanup (remove_stale_partials) leaves it alone;
            # HDF5 locks the file it writes itself, and a second lock would make its own fail.
            with nullcontext() if kind == "hdf5" else held(temporary):
                if kind == "hdf5":
                    from vptoolkit.dataset.store._hdf5 import Hdf5Sink

                    sink: _Sink = Hdf5Sink(temporary, root_attrs)
                else:
                    from vptoolkit.dataset.store._zarr import ZarrSink

                    sink = ZarrSink(require_zarr(), temporary, kind, root_attrs)
                try:
                    stored = {}
                    for name, spec in ARRAY_SPECS.items():
                        shape, chunks = layout[name]
                        stored[name] = sink.create(name, shape, spec.numpy_dtype, chunks,
                                                   digests[name])
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
    writers = {spec.name: _RowWriter(stored[spec.name], layout[spec.name][1][0])
               for spec in ENTRY_ARRAYS}
    n_views = layout["views"][0][0]
    n_measures = layout["best_index"][0][1]
    with progress_bar(total=len(plan.records), description=f"{label}: write", unit="model",
                      enabled=progress) as bar:
        for position, record in enumerate(plan.records):
            checked = _check_entry(entries[position], position, n_views, plan.n_points or None,
                                   n_measures, label)
            if _entry_checksum(checked) != plan.checksums[position]:
                raise VerificationError(
                    f"entries: model {record['name']!r} read differently on the second pass; "
                    "entries must be deterministic"
                )
            for spec in ENTRY_ARRAYS:  # a model's value is one row; its mesh, its own rows
                array = checked.arrays[spec.name]
                writers[spec.name].append(array[None] if spec.per == "model" else array)
            bar.update(1)
    for writer in writers.values():
        writer.finish()
