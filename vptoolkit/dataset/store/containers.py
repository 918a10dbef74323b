"""Which container a dataset store path names, and whether this install can read Zarr v3.

One layout (:mod:`vptoolkit.dataset.store.schema`, described in
``vptoolkit/dataset_card/SCHEMA.md``) is stored in one of three containers chosen by
the file name:

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
JSON list) names those keys. :class:`~vptoolkit.dataset.store.reader.StoreReader`
decodes them, so its ``attrs`` is the same dictionary for every container.

:func:`store_kind` maps a suffix to ``"zarr"``, ``"zarr-zip"`` or ``"hdf5"``;
:func:`find_store` picks the store a file or folder refers to;
:func:`zarr_is_usable` and :func:`require_zarr` say whether zarr >= 3 is
installed (the first without importing it). The writer
(:mod:`vptoolkit.dataset.store.writer`) and the reader
(:mod:`vptoolkit.dataset.store.reader`) both start here; each container's own
reading and writing lives in :mod:`vptoolkit.dataset.store._zarr` and
:mod:`vptoolkit.dataset.store._hdf5`, and ``zarr`` or ``h5py`` is imported inside
the functions that need it, only the one for the container in use.
"""

from __future__ import annotations

import importlib.metadata
import os
from pathlib import Path
from typing import Any

from vptoolkit.errors import InputError, MissingDependencyError
from vptoolkit.optional import is_available, require

__all__ = ["archive_preference", "find_store", "require_zarr", "store_kind", "zarr_is_usable"]


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
        If the path does not exist or no single store can be chosen; for a
        release of Parquet shards only, the message says how to load it.
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
    for suffixes in archive_preference():
        found = [p for p in visible if p.is_file() and p.name.lower().endswith(suffixes)]
        if len(found) == 1:
            return found[0]
        if len(found) > 1:
            names = ", ".join(p.name for p in found)
            raise InputError(f"{target}: holds {len(found)} stores ({names}); pass one of them")
    if any(visible_file.name.endswith(".parquet")
           for folder in (target, target / "data") if folder.is_dir()
           for visible_file in folder.iterdir()):
        raise InputError(
            f"{target}: a Parquet-only release, which vptool reads only as a *.zarr.zip or *.h5 "
            f"archive; load it with datasets (datasets.load_dataset('{target}')) or pyarrow, or "
            "pack the build again with --formats including zarr or hdf5"
        )
    raise InputError(
        f"{target}: no dataset.zarr, dataset.h5, *.zarr.zip or *.h5 store in this folder"
    )


def archive_preference() -> list[tuple[str, ...]]:
    """The suffixes of a release's archives, the one to open first first.

    The Zarr zip, then HDF5; HDF5 first where zarr >= 3 is missing and h5py
    is installed (a release may hold both: open the one this install reads).
    """
    containers: list[tuple[str, ...]] = [(".zarr.zip",), (".h5", ".hdf5")]
    if not zarr_is_usable() and is_available("h5py"):
        containers.reverse()
    return containers


def zarr_is_usable() -> bool:
    """Whether zarr >= 3 (which reads Zarr v3 stores) is installed, without importing it."""
    if not is_available("zarr"):
        return False
    try:
        major = importlib.metadata.version("zarr").split(".")[0]
    except importlib.metadata.PackageNotFoundError:
        return False
    return major.isdigit() and int(major) >= 3


def require_zarr() -> Any:
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
