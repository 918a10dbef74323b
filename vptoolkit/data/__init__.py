"""Load the viewpoint-quality dataset with numpy alone.

:func:`open_dataset` opens a store written by
:func:`vptoolkit.dataset.store.writer.write_dataset` (Zarr directory, Zarr zip or
HDF5; see ``vptoolkit/dataset_card/SCHEMA.md``) and returns a lazy
:class:`ViewpointDataset`: the per-model records and the view directions are
read at once, everything else only when an item is asked for.

This module needs numpy plus ``zarr`` or ``h5py`` for the container in use,
and never imports torch, open3d, pymeshlab, numba or trimesh at import time
(:meth:`ViewpointDataset.point_features` uses numba when called). The torch
adapter lives in :mod:`vptoolkit.data.torch`, which is not imported here.

Examples
--------
>>> with open_dataset("build/") as dataset:                    # doctest: +SKIP
...     train = dataset.split("train")
...     item = train[0]
...     item["points"].shape, item["quality"].shape, dataset.measures
((20000, 3), (1000, 4), ('VE', 'VR', 'VKL', 'VMI'))

A URL opens a published release through a verified local cache
(:mod:`vptoolkit.data.remote`, each file transferred by
:mod:`vptoolkit.data.download`); an HDF5 archive on an http(s) server that
serves byte ranges is read by ranges instead, only the parts asked for
(:mod:`vptoolkit.data.ranges`):

>>> dataset = open_dataset("https://example.org/viewpoints/")   # doctest: +SKIP

Size
    About 620 lines for one concept, the light loader: opening a store or a
    release, the lazy dataset and what it reads per model (items, arrays,
    meshes, view sets, point features, quality lookups). The remote,
    download and range readers are their own modules; what stays here shares
    the one open reader and the per-model records.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.camera import Camera
from vptoolkit.checks import one_line
from vptoolkit.conventions import SPLITS
from vptoolkit.data.ranges import RangeFile, RemoteArchive
from vptoolkit.data.remote import fetch_release, is_remote, locate_release
from vptoolkit.dataset.store.containers import find_store
from vptoolkit.dataset.store.reader import StoreReader, open_store
from vptoolkit.dataset.store.schema import ENTRY_ARRAYS, published_split, registered_measures
from vptoolkit.errors import InputError, VerificationError
from vptoolkit.sphere import nearest_view

if TYPE_CHECKING:
    from vptoolkit.view_sets.result import ViewSet

__all__ = ["ViewpointDataset", "open_dataset"]


class _SharedStore:
    """The open store and its small metadata, shared by a dataset and its splits.

    The reader is reopened after a fork (a new process id) and is left out
    when the object is copied to another process, so a dataset can be handed
    to the worker processes of a data loader. An archive read by ranges is
    reopened from its :class:`~vptoolkit.data.ranges.RemoteArchive` (URL,
    size, block settings), the path of its place in the cache naming it.
    """

    def __init__(self, path: Path, remote: RemoteArchive | None = None) -> None:
        self.path = path
        self.remote = remote
        self.is_closed = False
        self._reader: StoreReader | None = None
        self._stream: RangeFile | None = None
        self._pid = -1
        reader = self.reader()
        is_read = False
        try:
            self.attrs: dict[str, Any] = dict(reader.attrs)
            self.records: list[dict[str, Any]] = [
                {**record, "split": published_split(str(record["split"]))}
                for record in reader.models()
            ]
            self.failures: list[dict[str, Any]] = reader.failures()
            views = np.asarray(reader.array("views")[...], dtype=np.float64)
            best_index = np.asarray(reader.array("best_index")[...], dtype=np.int64)
            names, labels = reader.class_labels()
            is_read = True
        except (InputError, VerificationError) as err:
            served = self._served(err)
            if served is None:
                raise
            raise served from err
        finally:
            if not is_read:
                self.close()
        views.flags.writeable = False
        self.views: NDArray[np.float64] = views
        self.best_index: NDArray[np.int64] = best_index
        self.row_of_name = {record["name"]: row for row, record in enumerate(self.records)}
        self.class_names: list[str] = names
        self.labels: NDArray[np.int64] = labels
        self._vertex_offsets: NDArray[np.int64] | None = None
        self._face_offsets: NDArray[np.int64] | None = None

    def reader(self) -> StoreReader:
        if self.is_closed:
            raise InputError(f"{self.path.name}: dataset is closed")
        if self._reader is None or self._pid != os.getpid():
            self._stream = None if self.remote is None else self.remote.open()
            try:
                self._reader = open_store(self.path, stream=self._stream)
            except (InputError, VerificationError) as err:
                served = self._served(err)
                if served is None:
                    raise
                raise served from err
            self._pid = os.getpid()
        return self._reader

    def _served(self, error: InputError | VerificationError,
                ) -> InputError | VerificationError | None:
        """``error`` of reading an archive read by ranges, named by its server; None to
        raise ``error`` as it is (a local store, or the server's own answer naming the URL).

        The path names the archive's place in the cache, where it is not, and the
        bytes are the server's, unverified, so a damaged store is the server's answer.
        """
        if self.remote is None or str(error).startswith(self.remote.url):
            return None
        return type(error)(
            f"{self.remote.url}: the bytes served by ranges do not read as the archive "
            f"({one_line(error)}); the server may have changed them (partial=False "
            "downloads the whole archive and verifies it)")

    def offsets(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        if self._vertex_offsets is None or self._face_offsets is None:
            reader = self.reader()
            self._vertex_offsets = np.asarray(reader.array("mesh_vertex_offsets")[...], np.int64)
            self._face_offsets = np.asarray(reader.array("mesh_face_offsets")[...], np.int64)
        return self._vertex_offsets, self._face_offsets

    def close(self) -> None:
        if self._reader is not None and self._pid == os.getpid():
            self._reader.close()
            if self._stream is not None:
                self._stream.close()
        self._reader = None
        self._stream = None
        self.is_closed = True

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_reader"] = None
        state["_stream"] = None
        state["_pid"] = -1
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)


class ViewpointDataset:
    """A lazy, read-only view of the models of a dataset store.

    Create it with :func:`open_dataset`; :meth:`split` returns further
    datasets over the same open store.

    Items (``dataset[i]``, ``dataset["airplane_0001"]``, iteration) are
    dicts; a slice, a list or array of indices or a boolean mask
    (``dataset[0:3]``, ``dataset[[0, 2]]``) gives another dataset over those
    items, and :meth:`array` reads one key for every item at once:

    ==============  ==========================  ===================================
    key             value                       meaning
    ==============  ==========================  ===================================
    ``points``      (n_points, 3) float32       surface points, model coordinates
    ``normals``     (n_points, 3) float32       unit face normal at each point
    ``quality``     (n_views, K) float32        normalised quality, 1 = best
    ``quality_raw`` (n_views, K) float32        raw measures, NaN where nothing seen
    ``views``       (n_views, 3) float64        the view directions (shared, read-only)
    ``best_index``  (K,) int64                  best view per measure
    ``name``        str                         model name
    ``category``    str                         category
    ``label``       int                         class label: ``class_names[label] == category``
    ``split``       str                         ``"train"``, ``"validation"`` or ``"test"``
    ==============  ==========================  ===================================

    The last axis of size ``K`` holds one column per name of :attr:`measures`, the
    store's (by default the paper's four, ``("VE", "VR", "VKL", "VMI")``).
    Labels number the sorted category names of the whole store from 0
    (:attr:`class_names`), the same in every split and subset.
    """

    def __init__(self, shared: _SharedStore, rows: NDArray[np.int64], *,
                 split_name: str | None = None, is_owner: bool = False) -> None:
        self._shared = shared
        self._rows = rows
        self._split_name = split_name
        self._is_owner = is_owner
        self._position_of_name = {shared.records[row]["name"]: i for i, row in enumerate(rows)}

    # ------------------------------------------------------------------ metadata

    def __len__(self) -> int:
        return len(self._rows)

    def __repr__(self) -> str:
        split = f", split={self._split_name!r}" if self._split_name else ""
        return f"ViewpointDataset({str(self.path)!r}, n_models={len(self)}{split})"

    @property
    def path(self) -> Path:
        """Path of the store; for an archive read by ranges, its place in the cache (not there)."""
        return self._shared.path

    @property
    def names(self) -> list[str]:
        """Model names, in item order."""
        return [self._shared.records[row]["name"] for row in self._rows]

    @property
    def categories(self) -> list[str]:
        """Category of each model, in item order."""
        return [self._shared.records[row]["category"] for row in self._rows]

    @property
    def splits(self) -> list[str]:
        """Split of each model, in item order."""
        return [self._shared.records[row]["split"] for row in self._rows]

    @property
    def labels(self) -> NDArray[np.int64]:
        """Class label of each model, in item order (see :attr:`class_names`)."""
        return self._shared.labels[self._rows]

    @property
    def class_names(self) -> list[str]:
        """Category of each label: the store's sorted category names, label ``i`` at ``[i]``."""
        return list(self._shared.class_names)

    @property
    def records(self) -> list[dict[str, Any]]:
        """Each model's ``models_json`` record (SCHEMA.md), in item order."""
        return [dict(self._shared.records[row]) for row in self._rows]

    @property
    def measures(self) -> tuple[str, ...]:
        """Measure names as the store records them, the columns of every measure axis
        (``quality`` is ``(n_views, K)`` for ``K`` names)."""
        return tuple(self._shared.attrs["measures"])

    @property
    def higher_is_better(self) -> tuple[bool, ...]:
        """For each of :attr:`measures`, whether a higher raw value is better (from the
        measure registry; the normalised ``quality`` is always 1 = best).

        Raises
        ------
        InputError
            One line, for a measure the registry does not know (a store written by
            another version: its arrays load, but its direction is unknown).
        """
        return tuple(m.higher_is_better for m in registered_measures(self.measures,
                                                                     self.path.name))

    @property
    def views(self) -> NDArray[np.float64]:
        """View directions, ``(n_views, 3) float64``, read-only."""
        return self._shared.views

    @property
    def camera(self) -> Camera:
        """The camera of the measures: the root attribute ``camera`` (``Camera()`` without one)."""
        return Camera.from_dict(self._shared.attrs.get("camera") or {})

    @property
    def attrs(self) -> dict[str, Any]:
        """Root attributes of the store (a copy)."""
        return dict(self._shared.attrs)

    @property
    def failures(self) -> list[dict[str, Any]]:
        """Inputs the build could not process: ``{"source", "category", "reason"}``."""
        return [dict(failure) for failure in self._shared.failures]

    # ------------------------------------------------------------------ subsets

    def split(self, name: str) -> ViewpointDataset:
        """The models of one split, over the same open store.

        Parameters
        ----------
        name : str
            ``"train"``, ``"validation"`` or ``"test"``; ``"val"`` is an
            alias of ``"validation"``.

        Returns
        -------
        subset : ViewpointDataset
            Same API; closing it leaves the store open (close the dataset
            :func:`open_dataset` returned).

        Raises
        ------
        InputError
            For any other split name.
        """
        name = published_split(name)
        if name not in SPLITS:
            raise InputError(f"split: unknown split {name!r}, expected one of {list(SPLITS)}")
        records = self._shared.records
        rows = np.array([row for row in self._rows if records[row]["split"] == name], np.int64)
        return ViewpointDataset(self._shared, rows, split_name=name)

    def subset(self, names: Sequence[str]) -> ViewpointDataset:
        """The named models, in this dataset's order, over the same open store.

        Raises
        ------
        KeyError
            For a name that is not in this dataset.
        """
        wanted = set(names)
        missing = sorted(wanted - set(self._position_of_name))
        if missing:
            raise KeyError(f"{missing[0]}: no such model in {self.path.name}")
        rows = np.array([row for row, name in zip(self._rows, self.names) if name in wanted],
                        np.int64)
        return ViewpointDataset(self._shared, rows, split_name=self._split_name)

    # ------------------------------------------------------------------ items

    def row(self, key: int | str) -> int:
        """Row of a model in the store, from its item index or its name.

        Raises
        ------
        IndexError
            For an integer out of range (negative indices count from the end).
        KeyError
            For a name that is not in this dataset.
        """
        if isinstance(key, str):
            if key not in self._position_of_name:
                where = f" split {self._split_name!r} of" if self._split_name else ""
                raise KeyError(f"{key}: no such model in{where} {self.path.name}")
            return int(self._rows[self._position_of_name[key]])
        if isinstance(key, bool) or not isinstance(key, (int, np.integer)):
            raise InputError(f"key: expected an integer index or a model name, got {key!r}")
        if not -len(self) <= key < len(self):
            raise IndexError(f"index {key} out of range for {len(self)} models")
        return int(self._rows[int(key)])

    def record(self, key: int | str) -> dict[str, Any]:
        """One model's ``models_json`` record (SCHEMA.md), by item index or name."""
        return dict(self._shared.records[self.row(key)])

    @overload
    def __getitem__(self, key: int | np.integer | str) -> dict[str, Any]: ...

    @overload
    def __getitem__(self, key: slice | Sequence[int] | NDArray[Any]) -> ViewpointDataset: ...

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, (slice, list, tuple, np.ndarray)):
            return self._select(key)
        row = self.row(key)
        reader = self._shared.reader()
        record = self._shared.records[row]
        return {
            "points": np.asarray(reader.array("points")[row], dtype=np.float32),
            "normals": np.asarray(reader.array("normals")[row], dtype=np.float32),
            "quality": np.asarray(reader.array("quality")[row], dtype=np.float32),
            "quality_raw": np.asarray(reader.array("quality_raw")[row], dtype=np.float32),
            "views": self.views,
            "best_index": self._shared.best_index[row].copy(),
            "name": record["name"],
            "category": record["category"],
            "label": int(self._shared.labels[row]),
            "split": record["split"],
        }

    def _select(self, key: slice | Sequence[int] | NDArray[Any]) -> ViewpointDataset:
        if isinstance(key, slice):
            rows = self._rows[key]
        else:
            index = np.asarray(key)
            if index.dtype == bool:
                if index.shape != (len(self),):
                    raise IndexError(f"boolean index of shape {index.shape} for {len(self)} models")
                rows = self._rows[index]
            elif index.size == 0 or (index.ndim == 1 and index.dtype.kind in "iu"):
                index = index.astype(np.int64)
                outside = index[(index < -len(self)) | (index >= len(self))]
                if outside.size:
                    raise IndexError(f"index {outside[0]} out of range for {len(self)} models")
                rows = self._rows[index]
            else:
                raise InputError(f"key: expected integer indices or a boolean mask, got {key!r}")
        return ViewpointDataset(self._shared, np.asarray(rows, np.int64),
                                split_name=self._split_name)

    def array(self, key: str) -> NDArray[Any]:
        """One key of every item, stacked: e.g. ``array("quality")`` is ``(n, n_views, K)``.

        Parameters
        ----------
        key : str
            ``"points"``, ``"normals"``, ``"quality"``, ``"quality_raw"``
            (``(n, n_views, K)``, ``K`` the number of :attr:`measures`),
            ``"best_index"``, ``"best_value"``, ``"worst_index"``,
            ``"worst_value"`` (the store's per-model arrays, dtypes as in the
            items), ``"label"`` (int64), or ``"name"``, ``"category"``,
            ``"split"`` (numpy string arrays).

        Returns
        -------
        values : numpy.ndarray
            One row per item, in item order. Stored arrays are read a chunk
            at a time, so memory holds the result and one chunk.

        Raises
        ------
        InputError
            For another key.
        """
        if key in ("name", "category", "split"):
            return np.array([self._shared.records[row][key] for row in self._rows], dtype=str)
        if key == "label":
            return self.labels
        if key not in _STACKED:
            raise InputError("key: expected one of "
                             f"{['name', 'category', 'split', 'label', *_STACKED]}, "
                             f"got {key!r}")
        return _take_rows(self._shared.reader().array(key), self._rows, _STACKED[key])

    def __iter__(self) -> Iterator[dict[str, Any]]:
        for position in range(len(self)):
            yield self[position]

    def mesh(self, key: int | str) -> tuple[NDArray[np.float32], NDArray[np.int32]]:
        """The cleaned mesh of one model.

        Parameters
        ----------
        key : int or str
            Item index or model name.

        Returns
        -------
        vertices : (n_vertices, 3) float32
        faces : (n_faces, 3) int32
            Indices into ``vertices``.
        """
        row = self.row(key)
        vertex_offsets, face_offsets = self._shared.offsets()
        reader = self._shared.reader()
        vertices = reader.array("mesh_vertices")[vertex_offsets[row] : vertex_offsets[row + 1]]
        faces = reader.array("mesh_faces")[face_offsets[row] : face_offsets[row + 1]]
        return np.asarray(vertices, dtype=np.float32), np.asarray(faces, dtype=np.int32)

    def point_features(self, key: int | str, names: Sequence[str]) -> NDArray[np.float32]:
        """Features of one model's stored surface points.

        Face features (:data:`vptoolkit.point_features.FACE_FEATURES`) read
        each point's face: the nearest face of the stored mesh
        (:func:`vptoolkit.point_features.locate_faces`, numba from the
        ``measures`` extra). Cloud features
        (:data:`vptoolkit.point_features.CLOUD_FEATURES`) come from the
        stored points alone. Both are
        :func:`vptoolkit.point_features.point_features`.

        Parameters
        ----------
        key : int or str
            Item index or model name.
        names : sequence of str
            Names of :data:`vptoolkit.point_features.POINT_FEATURES`, in order.

        Returns
        -------
        features : (n_points, F) float32
            The names' columns (:func:`vptoolkit.point_features.feature_width`),
            in the stored points' coordinates; row ``i`` belongs to
            ``self[key]["points"][i]``.

        Raises
        ------
        InputError
            Naming the model: a face feature asked of a model stored without
            faces (a point cloud), or cloud features of 8 distinct points or
            fewer.
        """
        from vptoolkit.mesh import Mesh
        from vptoolkit.point_features import (
            CLOUD_FEATURES,
            FACE_FEATURES,
            check_feature_names,
            locate_faces,
            point_features,
        )

        names = check_feature_names(names)
        row = self.row(key)
        name = str(self._shared.records[row]["name"])
        points = np.asarray(self._shared.reader().array("points")[row], dtype=np.float64)
        if not any(feature in FACE_FEATURES for feature in names):
            try:
                return point_features(points, names)
            except InputError as error:
                raise InputError(f"{name}: {error}") from None
        vertices, faces = self.mesh(key)
        if not len(faces):
            raise InputError(f"{name}: stored without faces (a point cloud), so it has no "
                             f"point features of faces ({', '.join(names)}); train with the "
                             f"features of points ({', '.join(CLOUD_FEATURES)}) or none "
                             "(--point-features none)")
        mesh = Mesh(vertices.astype(np.float64), faces.astype(np.int64), name=name)
        return point_features(points, names, mesh=mesh, face_index=locate_faces(mesh, points))

    def view_set(self, key: int | str, k: int | None = None) -> ViewSet | None:
        """The model's greedy coverage view set, as the build stored it.

        Parameters
        ----------
        key : int or str
            Item index or model name.
        k : int, optional
            Keep the first ``k`` views (default: all stored, at most 6; fewer
            when more views would add nothing).

        Returns
        -------
        ViewSet or None
            Indices into :attr:`views`, directions and the coverage after each
            pick (:mod:`vptoolkit.view_sets`); None for a store built before
            view sets were stored.
        """
        from vptoolkit.view_sets.result import ViewSet

        record = self._shared.records[self.row(key)]
        stored = record.get("view_set")
        if stored is None:
            return None
        return ViewSet.from_record(stored, self.views, name=str(record["name"]), k=k)

    def quality_of(self, key: int | str, directions: ArrayLike) -> NDArray[np.float32]:
        """Normalised quality of arbitrary directions, by nearest sampled view.

        The authors' evaluation protocol: a direction scores the normalised
        quality of the sampled view closest to it in angle
        (:func:`vptoolkit.sphere.nearest_view`).

        Parameters
        ----------
        key : int or str
            Item index or model name.
        directions : (n, 3) or (3,) array_like
            Directions from the model centre, any non-zero length.

        Returns
        -------
        quality : (n, K) float32
            One row per direction, one column per measure of :attr:`measures`
            (a single direction gives ``(1, K)``).

        Raises
        ------
        InputError
            On a wrong shape, non-finite values or a zero vector.
        """
        row = self.row(key)
        nearest = nearest_view(directions, self.views)
        quality = np.asarray(self._shared.reader().array("quality")[row], dtype=np.float32)
        return quality[nearest]

    # ------------------------------------------------------------------ lifetime

    def close(self) -> None:
        """Close the store (for the dataset :func:`open_dataset` returned).

        Closing a dataset from :meth:`split` does nothing; its items stay
        readable until the original dataset is closed.
        """
        if self._is_owner:
            self._shared.close()

    def __enter__(self) -> ViewpointDataset:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


_STACKED: dict[str, type[np.generic]] = {
    spec.name: spec.numpy_dtype.type for spec in ENTRY_ARRAYS if spec.per == "model"}


def _take_rows(array: Any, rows: NDArray[np.int64], dtype: type[np.generic]) -> NDArray[Any]:
    """``array[rows]`` for a lazy per-model array, read one chunk of rows at a time."""
    out = np.empty((len(rows), *array.shape[1:]), dtype=dtype)
    order = np.argsort(rows, kind="stable")
    wanted = rows[order]
    step = max(1, int((array.chunks or (1,))[0]))
    first = 0
    while first < len(wanted):
        start = int(wanted[first]) // step * step
        stop = int(np.searchsorted(wanted, start + step))
        block = np.asarray(array[start : min(start + step, int(array.shape[0]))])
        out[order[first:stop]] = block[wanted[first:stop] - start]
        first = stop
    return out


def open_dataset(path: str | os.PathLike[str], *,
                 cache_dir: str | os.PathLike[str] | None = None,
                 partial: bool = True) -> ViewpointDataset:
    """Open a dataset store lazily, local or remote.

    Parameters
    ----------
    path : path-like or str
        A store (``*.zarr``, ``*.zarr.zip``, ``*.h5``), a build output folder
        or a release folder (see :func:`vptoolkit.dataset.store.containers.find_store`);
        or the URL of a release folder or archive (``https://...``,
        ``hf://datasets/...``, ``s3://...``), which is downloaded, verified
        against its ``SHA256SUMS`` and read from the local cache
        (:func:`vptoolkit.data.remote.fetch_release`).
    cache_dir : path-like, optional
        Cache folder for a URL (default: ``$XDG_CACHE_HOME/vptoolkit``, else
        ``~/.cache/vptoolkit``).
    partial : bool
        For a URL whose HDF5 archive is not cached yet, on an http(s) server
        that serves byte ranges: read the archive by ranges, only the parts
        asked for, checked against the size ``croissant.json`` records but
        not against its SHA-256, which covers the whole file
        (:func:`vptoolkit.data.remote.locate_release`; the manifest,
        ``croissant.json`` and the card are verified as always). False
        downloads the whole archive and verifies it first (default: True).

    Returns
    -------
    dataset : ViewpointDataset
        All models, in store order (sorted by category, then name).

    Raises
    ------
    InputError
        If no store is found, it cannot be read or a URL cannot be fetched.
    VerificationError
        If the store's ``measures`` and ``higher_is_better`` disagree with each
        other, the registry or the arrays
        (:func:`~vptoolkit.dataset.store.reader.open_store`), or a downloaded
        file differs from the release's ``SHA256SUMS`` (it is not cached).
    MissingDependencyError
        For a URL other than http(s) without fsspec (the ``remote`` extra).
    """
    if is_remote(path):
        located = (locate_release(str(path), cache_dir=cache_dir) if partial
                   else fetch_release(str(path), cache_dir=cache_dir))
        shared = (_SharedStore(located.path, located) if isinstance(located, RemoteArchive)
                  else _SharedStore(find_store(located)))
    else:
        shared = _SharedStore(find_store(path))
    rows = np.arange(len(shared.records), dtype=np.int64)
    return ViewpointDataset(shared, rows, is_owner=True)
