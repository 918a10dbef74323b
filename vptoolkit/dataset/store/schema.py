"""The data contract of a viewpoint-quality dataset store (schema version 1).

What every container holds, independent of how it is stored: the ``format``
name and ``schema_version``, the root array names (:data:`ARRAY_NAMES`), the
root attributes the build and the writer set (:data:`BUILD_ATTRS`,
:data:`WRITER_ATTRS`), the aliases of the split names of
:data:`vptoolkit.conventions.SPLITS` (:data:`SPLIT_ALIASES`,
:func:`published_split`), the keys of a failure record (:data:`FAILURE_KEYS`),
one model's content (:class:`ModelEntry`), the unit-normal rule
(:data:`NORMAL_TOLERANCE`, :func:`normal_length_problem`), the JSON text encoding
(:func:`json_bytes`, :func:`from_json_bytes`) and the array digest
(:func:`array_sha256`). Described in ``vptoolkit/dataset_card/SCHEMA.md``.

Needs numpy only.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.errors import InputError
from vptoolkit.files import parse_json

__all__ = [
    "FORMAT_NAME",
    "SCHEMA_VERSION",
    "ARRAY_NAMES",
    "STRING_ARRAYS",
    "BUILD_ATTRS",
    "WRITER_ATTRS",
    "SPLIT_ALIASES",
    "published_split",
    "class_labels",
    "class_names",
    "FAILURE_KEYS",
    "HDF5_JSON_KEY",
    "NORMAL_TOLERANCE",
    "ModelEntry",
    "normal_length_problem",
    "array_sha256",
    "le_bytes",
    "json_bytes",
    "string_values",
    "from_json_bytes",
]

FORMAT_NAME = "vptoolkit-viewpoint-dataset"
"""Value of the root attribute ``format``."""

SCHEMA_VERSION = 1
"""Value of the root attribute ``schema_version`` written and read here."""

ARRAY_NAMES = (
    "views",
    "points",
    "normals",
    "quality",
    "quality_raw",
    "best_index",
    "best_value",
    "worst_index",
    "worst_value",
    "mesh_vertices",
    "mesh_vertex_offsets",
    "mesh_faces",
    "mesh_face_offsets",
    "models_json",
    "failures_json",
    "names",
    "categories",
    "splits",
    "labels",
)
"""Every root array of a store, in the order of SCHEMA.md."""

STRING_ARRAYS = ("names", "categories", "splits")
"""Root arrays of UTF-8 strings, one per model: readable with h5py or zarr alone."""

BUILD_ATTRS = (
    "resolution",
    "backend",
    "camera",
    "cleaning",
    "split_seed",
    "split_fractions",
    "source",
    "toolkit_version",
    "created",
)
"""Root attributes the build must pass to
:func:`~vptoolkit.dataset.store.writer.write_dataset` in ``attrs``."""

WRITER_ATTRS = (
    "format",
    "schema_version",
    "measures",
    "higher_is_better",
    "n_models",
    "n_views",
    "n_points",
    "n_failures",
    "class_names",
)
"""Root attributes :func:`~vptoolkit.dataset.store.writer.write_dataset` sets itself
(``class_names`` may also be passed, see :func:`class_names`)."""

SPLIT_ALIASES = {"val": "validation"}
"""Other names a model record or a caller may use for a split of
:data:`~vptoolkit.conventions.SPLITS`."""


def published_split(name: str) -> str:
    """The name in :data:`~vptoolkit.conventions.SPLITS` of a split, resolving aliases.

    Examples
    --------
    >>> published_split("val"), published_split("test")
    ('validation', 'test')
    """
    return SPLIT_ALIASES.get(name, name)


def class_names(categories: Iterable[str], given: Sequence[str] | None = None) -> list[str]:
    """The class labels of a dataset: category ``class_names[i]`` has label ``i``.

    Parameters
    ----------
    categories : iterable of str
        The category of every model.
    given : sequence of str, optional
        A map to keep (e.g. a subset's parent's ``class_names``, so labels
        stay the same): sorted, unique, and holding every category.

    Returns
    -------
    names : list of str
        ``given``, else the sorted distinct categories.

    Raises
    ------
    InputError
        If ``given`` is not sorted and unique strings or lacks a category.

    Examples
    --------
    >>> class_names(["mug", "bottle", "mug"])
    ['bottle', 'mug']
    """
    found = sorted({str(category) for category in categories})
    if given is None:
        return found
    names = list(given)
    if not all(isinstance(name, str) for name in names) or names != sorted(set(names)):
        raise InputError("class_names: expected sorted, unique category names")
    missing = sorted(set(found) - set(names))
    if missing:
        raise InputError(f"class_names: category {missing[0]!r} has no label")
    return names


def class_labels(categories: Sequence[str],
                 given: Sequence[str] | None = None) -> tuple[list[str], NDArray[np.int64]]:
    """The class names of a dataset and the class label of each model.

    Parameters
    ----------
    categories : sequence of str
        The category of every model, in row order.
    given : sequence of str, optional
        A map to keep (see :func:`class_names`).

    Returns
    -------
    names : list of str
        :func:`class_names` of ``categories`` and ``given``.
    labels : (n_models,) int64
        Label of each model: ``names[labels[i]] == categories[i]``.

    Raises
    ------
    InputError
        As :func:`class_names`.

    Examples
    --------
    >>> names, labels = class_labels(["mug", "bottle", "mug"])
    >>> names, labels.tolist()
    (['bottle', 'mug'], [1, 0, 1])
    """
    names = class_names(categories, given)
    label_of = {name: label for label, name in enumerate(names)}
    return names, np.array([label_of[str(category)] for category in categories], np.int64)


FAILURE_KEYS = ("source", "category", "reason")
"""The keys of one record of ``failures_json``."""

HDF5_JSON_KEY = "json_attributes"
"""Root attribute of an HDF5 store naming its JSON-encoded root attributes."""

NORMAL_TOLERANCE = 1e-3
"""How far the length of a stored normal may be from 1."""

_HASH_BLOCK_BYTES = 1 << 26  # bytes read at a time when hashing a lazy array


@dataclass(frozen=True, eq=False)
class ModelEntry:
    """One model as it goes into or comes out of a store.

    :func:`~vptoolkit.dataset.store.writer.write_dataset` checks shapes and casts
    the arrays to the stored dtypes given below;
    :meth:`~vptoolkit.dataset.store.reader.StoreReader.entry` returns them in those
    dtypes.

    Attributes
    ----------
    name : str
        Unique model name, e.g. ``"airplane_0001"``.
    category : str
        Category, e.g. ``"airplane"``.
    split : str
        ``"train"``, ``"validation"`` (or its alias ``"val"``) or ``"test"``.
    source : str
        Path of the source mesh relative to the source folder.
    source_sha256 : str
        SHA-256 hex digest (64 lower-case hex digits) of the source file.
    points : (n_points, 3) float32
        Points sampled uniformly by area on the cleaned mesh.
    normals : (n_points, 3) float32
        Unit face normal at each point.
    quality : (n_views, 4) float32
        Normalised quality in [0, 1], 1 = best, in ``MEASURES`` order.
    quality_raw : (n_views, 4) float32
        Raw measures; NaN where a view sees nothing.
    best_index, worst_index : (4,) int64
        Index into the views of the best and worst view per measure.
    best_value, worst_value : (4,) float32
        Raw value at the best and worst view per measure.
    vertices : (n_vertices, 3) float32
        Cleaned mesh vertices.
    faces : (n_faces, 3) int32
        Triangles, indices into ``vertices``.
    cleaning : dict or None
        JSON-safe cleaning report, or None when built without cleaning.
    view_set : dict or None
        The greedy coverage view set (SCHEMA.md, "Model record"): ``objective``,
        ``min_pixels``, ``indices``, ``coverage`` and ``reachable``; None in
        stores built before view sets (the record then has no ``view_set`` key).
    """

    name: str
    category: str
    split: str
    source: str
    source_sha256: str
    points: NDArray[Any]
    normals: NDArray[Any]
    quality: NDArray[Any]
    quality_raw: NDArray[Any]
    best_index: NDArray[Any]
    best_value: NDArray[Any]
    worst_index: NDArray[Any]
    worst_value: NDArray[Any]
    vertices: NDArray[Any]
    faces: NDArray[Any]
    cleaning: dict[str, Any] | None = None
    view_set: dict[str, Any] | None = None

    def record(self) -> dict[str, Any]:
        """The model's record in ``models_json`` (SCHEMA.md, "Model record").

        Returns
        -------
        record : dict
            ``name``, ``category``, ``split``, ``source``, ``source_sha256``,
            ``n_vertices``, ``n_faces`` and ``cleaning``, in that order, then
            ``view_set`` when the entry has one.
        """
        record = {
            "name": self.name,
            "category": self.category,
            "split": self.split,
            "source": self.source,
            "source_sha256": self.source_sha256,
            "n_vertices": int(np.shape(self.vertices)[0]),
            "n_faces": int(np.shape(self.faces)[0]),
            "cleaning": self.cleaning,
        }
        if self.view_set is not None:
            record["view_set"] = self.view_set
        return record


def normal_length_problem(normals: ArrayLike) -> str | None:
    """Say which normals are not unit vectors, or None when all are.

    A normal passes when ``abs(1 - |n|) <= NORMAL_TOLERANCE``, its length
    computed in float64; zero, NaN and overflowing lengths fail.

    Parameters
    ----------
    normals : (n_points, 3) array_like
        The normals, finite numbers of any float dtype.

    Returns
    -------
    problem : str or None
        E.g. ``"200 of 500 normals are not of unit length (the first, normal 1,
        has length 0)"``, for the caller to put after the file or model.

    Examples
    --------
    >>> normal_length_problem([[0.0, 0.0, 1.0], [0.0, 0.0, 7.0]])
    '1 of 2 normals are not of unit length (the first, normal 2, has length 7)'
    """
    values = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    with np.errstate(over="ignore", invalid="ignore"):
        lengths = np.sqrt(np.square(values).sum(axis=1))
    bad = np.flatnonzero(~(np.abs(1.0 - lengths) <= NORMAL_TOLERANCE))
    if not bad.size:
        return None
    return (f"{bad.size} of {len(values)} normals are not of unit length (the first, normal "
            f"{bad[0] + 1}, has length {lengths[bad[0]]:.6g})")


# --------------------------------------------------------------------------- digests and JSON


class _ArrayLike(Protocol):
    shape: tuple[int, ...]
    dtype: np.dtype[Any]

    def __getitem__(self, key: Any) -> Any: ...


def le_bytes(array: NDArray[Any]) -> NDArray[np.uint8]:
    """The C-order little-endian bytes of an array, as a flat uint8 view (copied only if needed)."""
    return np.ascontiguousarray(array, array.dtype.newbyteorder("<")).reshape(-1).view(np.uint8)


def array_sha256(array: NDArray[Any] | _ArrayLike) -> str:
    """SHA-256 of an array's content, as stored in its ``sha256`` attribute.

    The digest covers the C-order little-endian bytes,
    ``np.ascontiguousarray(a, a.dtype.newbyteorder("<")).tobytes()``; shape
    and dtype are not part of it.

    A string array (:data:`STRING_ARRAYS`) is hashed as the compact UTF-8
    JSON list of its values (:func:`json_bytes`), so the digest is the same
    for zarr's and h5py's string types.

    Parameters
    ----------
    array : numpy.ndarray or lazy array
        An in-memory array, or a ``zarr.Array`` / ``h5py.Dataset`` (anything
        with ``shape``, ``dtype`` and slicing), which is read in blocks of
        rows so that it never has to fit in memory at once.

    Returns
    -------
    digest : str
        64 lower-case hex digits.
    """
    hasher = hashlib.sha256()
    if np.dtype(getattr(array, "dtype", np.uint8)).kind in "OTUS":
        hasher.update(json_bytes(string_values(array[...])).data)
        return hasher.hexdigest()
    if isinstance(array, np.ndarray) or not hasattr(array, "shape") or not array.shape:
        hasher.update(le_bytes(np.asarray(array)).data)
        return hasher.hexdigest()
    n_rows = int(array.shape[0])
    row_bytes = max(1, math.prod(array.shape[1:]) * np.dtype(array.dtype).itemsize)
    step = max(1, _HASH_BLOCK_BYTES // row_bytes)
    for start in range(0, n_rows, step):
        hasher.update(le_bytes(np.asarray(array[start : start + step])).data)
    return hasher.hexdigest()


def string_values(array: ArrayLike) -> list[str]:
    """The values of a string array as ``str`` (h5py reads UTF-8 bytes, zarr ``str``)."""
    return [value.decode("utf-8") if isinstance(value, bytes) else str(value)
            for value in np.asarray(array).tolist()]


def json_bytes(obj: Any, *, sort_keys: bool = False) -> NDArray[np.uint8]:
    """Encode a JSON-safe object as UTF-8 JSON in a ``uint8`` array.

    Parameters
    ----------
    obj : JSON-safe object
        Dicts with string keys, lists, strings, finite numbers, booleans, None.
    sort_keys : bool
        Write the keys of every dict sorted (default: in their order).

    Returns
    -------
    encoded : (n_bytes,) uint8
        Compact JSON (no spaces), non-ASCII characters kept as UTF-8.

    Raises
    ------
    InputError
        If ``obj`` holds something JSON cannot represent (NaN included).
    """
    try:
        text = json.dumps(obj, ensure_ascii=False, allow_nan=False, separators=(",", ":"),
                          sort_keys=sort_keys)
    except (TypeError, ValueError) as err:
        raise InputError(f"obj: not JSON-serialisable ({err})") from err
    return np.frombuffer(text.encode("utf-8"), dtype=np.uint8).copy()


def from_json_bytes(array: ArrayLike) -> Any:
    """Decode a ``uint8`` array written by :func:`json_bytes`.

    Parameters
    ----------
    array : (n_bytes,) uint8 array_like
        UTF-8 JSON text.

    Returns
    -------
    obj : Any
        The decoded JSON value.

    Raises
    ------
    InputError
        If the bytes are not valid UTF-8 JSON (:func:`vptoolkit.files.parse_json`).
    """
    raw = np.asarray(array)
    if raw.dtype != np.uint8 or raw.ndim != 1:
        raise InputError(f"array: expected (n,) uint8 JSON bytes, got {raw.shape} {raw.dtype}")
    return parse_json(raw.tobytes(), "array")
