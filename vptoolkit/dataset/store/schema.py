"""The data contract of a viewpoint-quality dataset store (schema version 1).

What every container holds, independent of how it is stored: the ``format``
name and ``schema_version``; the root arrays, declared once
(:class:`ArraySpec`, :data:`ARRAY_SPECS`), from which :data:`ARRAY_NAMES`,
:data:`ENTRY_ARRAYS` and :data:`STRING_ARRAYS` are read, and so are the
writer's dtypes, shapes and chunks, the reader's models of each row, a
build's staged members and a release's Parquet columns; the root attributes
the build and the writer set (:data:`BUILD_ATTRS`, :data:`WRITER_ATTRS`) and the
registered measures the ``measures`` attribute names (:func:`registered_measures`); the
aliases of the split names of :data:`vptoolkit.conventions.SPLITS`
(:data:`SPLIT_ALIASES`, :func:`published_split`); the keys of a failure
record (:data:`FAILURE_KEYS`); one model's content (:class:`ModelEntry`) and a
lazy sequence of them (:class:`~vptoolkit.dataset.store.entries.LazyEntries`); the unit-normal rule
(:data:`NORMAL_TOLERANCE`, :func:`normal_length_problem`); the JSON text
encoding (:func:`json_bytes`, :func:`from_json_bytes`) and the array digest
(:func:`array_sha256`). Described in ``vptoolkit/dataset_card/SCHEMA.md``.

Needs numpy (and :mod:`vptoolkit.conventions`) only; :func:`registered_measures` imports
the measure registry (:mod:`vptoolkit.measures.registry`, numpy alone) when called.

Size
    About 700 lines for one concept, the data contract of SCHEMA.md that
    every stage reads: the arrays' declarations, the model they make up and
    its lazy sequence stay beside the attributes, split names and encodings
    of the same contract, so that a store's layout is read in one place.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Literal, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.errors import InputError
from vptoolkit.files import parse_json

if TYPE_CHECKING:
    from vptoolkit.measures.measure import Measure

__all__ = [
    "FORMAT_NAME",
    "SCHEMA_VERSION",
    "ArraySpec",
    "ARRAY_SPECS",
    "ARRAY_NAMES",
    "ENTRY_ARRAYS",
    "STRING_ARRAYS",
    "BUILD_ATTRS",
    "WRITER_ATTRS",
    "registered_measures",
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

_CHUNK_MODELS = 64  # models per chunk of the per-model arrays other than points and normals
_CHUNK_ROWS = 1 << 16  # rows per chunk of the mesh arrays, their offsets and the string arrays
_CHUNK_BYTES = 1 << 22  # bytes per chunk of the JSON arrays


@dataclass(frozen=True)
class ArraySpec:
    """One root array of a store: its name, dtype, shape, chunks and the models its rows hold.

    Attributes
    ----------
    name : str
        The array's name in the store.
    dtype : str
        A numpy dtype name (``"float32"``, ``"int64"``, ...), stored
        little-endian, or ``"string"``: UTF-8 strings (:data:`STRING_ARRAYS`).
    per : {"model", "mesh", "root"}
        Which rows belong to which model. ``"model"``: the models' values
        stacked, row ``m`` is model ``m`` and the array is
        ``(n_models, *shape)``. ``"mesh"``: each model owns a run of rows of
        varying length, model ``m`` the rows ``o[m]:o[m + 1]`` of the
        ``offsets`` array ``o``. ``"root"``: the array as a whole, not split
        by model.
    shape : tuple of int, str or None
        The shape of one model's value (``"model"``), of one model's rows
        (``"mesh"``, first axis None) or of the whole array (``"root"``). A
        string names a size: ``"n_points"``, ``"n_views"``, ``"n_measures"``
        (the length of the root attribute ``measures``); None is a length set
        by the content (the rows of a mesh, the bytes of a JSON text,
        ``n_models + 1`` offsets).
    chunk_rows : int or None
        Rows along the first axis per chunk (models, for ``"model"``); None
        stores the array as one chunk.
    description : str
        What the array holds, as the dataset card's table of arrays says it.
    field : str
        The :class:`ModelEntry` attribute holding a model's value (its rows,
        for ``"mesh"``); empty for an array the writer makes itself, from
        the records, the class labels or the views.
    offsets : str
        For ``"mesh"``, the ``(n_models + 1,)`` int64 array of row offsets;
        else empty.
    column : str
        What a model's value holds, as the Parquet column of a release that
        carries it describes it, ``{measures}`` standing for the store's
        measure names (:meth:`column_for`); empty for an array with no such
        column.
    """

    name: str
    dtype: str
    per: Literal["model", "mesh", "root"]
    shape: tuple[int | str | None, ...]
    chunk_rows: int | None
    description: str
    field: str = ""
    offsets: str = ""
    column: str = ""

    @property
    def numpy_dtype(self) -> np.dtype[Any]:
        """The stored numpy dtype: little-endian, ``object`` for a string array (as the
        containers' writers take one)."""
        if self.dtype == "string":
            return np.dtype(object)
        return np.dtype(self.dtype).newbyteorder("<")

    def resolve(self, sizes: Mapping[str, int | None]) -> tuple[int | None, ...]:
        """:attr:`shape` with its named sizes taken from ``sizes``.

        Parameters
        ----------
        sizes : mapping of str to int or None
            ``"n_points"``, ``"n_views"`` and ``"n_measures"`` (the
            number of the store's measures), each that :attr:`shape` names;
            a size of None stays None (any length).

        Returns
        -------
        shape : tuple of int or None
            None where the length varies or the size is not known.

        Examples
        --------
        >>> ARRAY_SPECS["quality"].resolve({"n_points": 200, "n_views": 50, "n_measures": 4})
        (50, 4)
        >>> ARRAY_SPECS["best_index"].resolve({"n_measures": 3})
        (3,)
        >>> ARRAY_SPECS["mesh_faces"].resolve({})
        (None, 3)
        """
        missing = [axis for axis in self.shape if isinstance(axis, str) and axis not in sizes]
        if missing:
            raise KeyError(f"{self.name}: no size given for {', '.join(missing)}")
        return tuple(sizes[axis] if isinstance(axis, str) else axis for axis in self.shape)

    def column_for(self, measures: Sequence[str]) -> str:
        """:attr:`column` for a store of these measures: their names, comma-separated, in
        place of ``{measures}``.

        Examples
        --------
        >>> ARRAY_SPECS["quality"].column_for(("VE", "NVT", "SL"))
        'normalised quality per view, columns VE, NVT, SL, 1 = best'
        """
        return self.column.replace("{measures}", ", ".join(measures))


ARRAY_SPECS: Mapping[str, ArraySpec] = MappingProxyType({spec.name: spec for spec in (
    ArraySpec("views", "float64", "root", ("n_views", 3), None,
              "unit view directions, model centre to camera (Fibonacci sphere)"),
    ArraySpec("points", "float32", "model", ("n_points", 3), 1,
              "points sampled uniformly by area on the cleaned mesh", field="points",
              column="points sampled by area on the cleaned mesh"),
    ArraySpec("normals", "float32", "model", ("n_points", 3), 1,
              "unit face normal at each point", field="normals",
              column="unit face normal at each point"),
    ArraySpec("quality", "float32", "model", ("n_views", "n_measures"), _CHUNK_MODELS,
              "normalised quality in [0, 1], 1 = best", field="quality",
              column="normalised quality per view, columns {measures}, 1 = best"),
    ArraySpec("quality_raw", "float32", "model", ("n_views", "n_measures"), _CHUNK_MODELS,
              "raw measures, NaN where a view sees nothing", field="quality_raw",
              column="raw measures per view, columns {measures}, NaN where nothing is seen"),
    ArraySpec("best_index", "int64", "model", ("n_measures",), _CHUNK_MODELS,
              "index into `views` of the best view per measure", field="best_index",
              column="index of the best view per measure"),
    ArraySpec("best_value", "float32", "model", ("n_measures",), _CHUNK_MODELS,
              "raw value at the best view", field="best_value",
              column="raw value at the best view"),
    ArraySpec("worst_index", "int64", "model", ("n_measures",), _CHUNK_MODELS,
              "index into `views` of the worst view per measure", field="worst_index",
              column="index of the worst view per measure"),
    ArraySpec("worst_value", "float32", "model", ("n_measures",), _CHUNK_MODELS,
              "raw value at the worst view", field="worst_value",
              column="raw value at the worst view"),
    ArraySpec("mesh_vertices", "float32", "mesh", (None, 3), _CHUNK_ROWS,
              "cleaned mesh vertices of all models, concatenated", field="vertices",
              offsets="mesh_vertex_offsets", column="vertices of the cleaned mesh"),
    ArraySpec("mesh_vertex_offsets", "int64", "root", (None,), _CHUNK_ROWS,
              "model m owns vertex rows offsets[m]:offsets[m+1]"),
    ArraySpec("mesh_faces", "int32", "mesh", (None, 3), _CHUNK_ROWS,
              "faces, indices local to the model's vertices", field="faces",
              offsets="mesh_face_offsets", column="triangles, indices into mesh_vertices"),
    ArraySpec("mesh_face_offsets", "int64", "root", (None,), _CHUNK_ROWS,
              "model m owns face rows offsets[m]:offsets[m+1]"),
    ArraySpec("models_json", "uint8", "root", (None,), _CHUNK_BYTES,
              "UTF-8 JSON list of model records in row order"),
    ArraySpec("failures_json", "uint8", "root", (None,), _CHUNK_BYTES,
              "UTF-8 JSON list of inputs that could not be processed"),
    ArraySpec("names", "string", "model", (), _CHUNK_ROWS, "model name per model, in row order"),
    ArraySpec("categories", "string", "model", (), _CHUNK_ROWS, "category per model"),
    ArraySpec("splits", "string", "model", (), _CHUNK_ROWS,
              "split per model: train, validation or test"),
    ArraySpec("labels", "int64", "model", (), _CHUNK_ROWS,
              "class label per model: index into the root attribute `class_names`",
              column="class label: the category's index in the sorted category names"),
)})
"""Every root array of a store by name, in the order of SCHEMA.md: the one declaration the
writer, the reader, a build's staging and a release's Parquet columns are derived from."""

ARRAY_NAMES = tuple(ARRAY_SPECS)
"""Every root array of a store, in the order of SCHEMA.md."""

ENTRY_ARRAYS = tuple(spec for spec in ARRAY_SPECS.values() if spec.field)
"""The arrays of :data:`ARRAY_SPECS` a :class:`ModelEntry` carries, in store order
(``points`` first)."""

STRING_ARRAYS = tuple(spec.name for spec in ARRAY_SPECS.values() if spec.dtype == "string")
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
(``class_names`` may also be passed, see :func:`class_names`; ``measures``, the names
of the columns of every measure axis, is taken from the build's attributes, the paper's
four by default, and ``higher_is_better`` from the registry for those names)."""


def registered_measures(names: Sequence[str], where: str) -> tuple[Measure, ...]:
    """The registry's measures (:func:`~vptoolkit.measures.registry.get_measure`) of a
    store's ``measures`` attribute, for what needs their titles or directions.

    A store may record a measure this vptoolkit does not know (written by another
    version): its arrays load all the same, but which way it is better, or what it is
    called, is known only from the registry.

    Parameters
    ----------
    names : sequence of str
        Measure names, e.g. the root attribute ``measures``.
    where : str
        What the names belong to (the store's file name), at the start of the message.

    Returns
    -------
    tuple of Measure
        One per name, in order.

    Raises
    ------
    InputError
        One line naming the first unknown measure.

    Examples
    --------
    >>> [m.higher_is_better for m in registered_measures(["VE", "VKL"], "d.h5")]
    [True, False]
    """
    from vptoolkit.measures.registry import all_measures

    known = all_measures()
    unknown = [name for name in names if name not in known]
    if unknown:
        raise InputError(
            f"{where}: measure {unknown[0]!r} is not one this vptoolkit knows, so which way "
            f"it is better is unknown (known: {', '.join(known)})")
    return tuple(known[name] for name in names)

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
    quality : (n_views, K) float32
        Normalised quality in [0, 1], 1 = best, one column per measure of the
        store's ``measures`` (by default the paper's four,
        :data:`~vptoolkit.measures.registry.PAPER_MEASURES`, ``K = 4``).
    quality_raw : (n_views, K) float32
        Raw measures; NaN where a view sees nothing.
    best_index, worst_index : (K,) int64
        Index into the views of the best and worst view per measure.
    best_value, worst_value : (K,) float32
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
