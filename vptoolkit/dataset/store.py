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

This module is the public API and re-exports every name from the modules that
own it: :mod:`vptoolkit.dataset.schema` (the data contract),
:mod:`vptoolkit.dataset.containers` (which container a path names,
:func:`store_kind`, :func:`find_store`, :func:`zarr_is_usable`),
:mod:`vptoolkit.dataset.writer` (:func:`write_dataset`: checking entries,
chunk layout, atomic replacement) and :mod:`vptoolkit.dataset.reader`
(:func:`open_store`, :class:`StoreReader`, root checks). Each container's
own reading and writing lives in :mod:`vptoolkit.dataset._zarr` and
:mod:`vptoolkit.dataset._hdf5`, imported inside the functions that use them.
"""

from __future__ import annotations

from vptoolkit.dataset.containers import find_store, store_kind, zarr_is_usable
from vptoolkit.dataset.reader import StoreReader, open_store
from vptoolkit.dataset.schema import (
    ARRAY_NAMES,
    BUILD_ATTRS,
    FAILURE_KEYS,
    FORMAT_NAME,
    SCHEMA_VERSION,
    SPLIT_ALIASES,
    SPLITS,
    WRITER_ATTRS,
    ModelEntry,
    array_sha256,
    from_json_bytes,
    json_bytes,
    published_split,
)
from vptoolkit.dataset.writer import write_dataset

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
