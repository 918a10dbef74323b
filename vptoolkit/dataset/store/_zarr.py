"""The Zarr v3 containers of a dataset store: ``*.zarr`` directories and ``*.zarr.zip`` files.

Owns writing (:class:`ZarrSink`, Blosc/zstd chunks, every chunk stored, zip
entries normalised), opening for reading (:func:`open_zarr`) and the check
that no chunk is missing (:func:`check_chunks`). The ``zarr`` module is
passed in by :mod:`vptoolkit.dataset.store.writer` and :mod:`vptoolkit.dataset.store.reader`
(from :func:`vptoolkit.dataset.store.containers.require_zarr`), which import this
module lazily, inside the functions that use it; importing it imports no
``zarr``, so ``zarr`` stays optional.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import itertools
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from vptoolkit.dataset.store.schema import array_sha256
from vptoolkit.errors import VerificationError

__all__ = ["ZarrSink", "open_zarr", "check_chunks"]


class ZarrSink:
    """Writes a Zarr v3 hierarchy to a directory or a zip file."""

    def __init__(self, zarr: Any, path: Path, kind: str, root_attrs: dict[str, Any]) -> None:
        self._codec = zarr.codecs.BloscCodec(
            cname="zstd", clevel=5, shuffle=zarr.codecs.BloscShuffle.shuffle
        )
        self._zip_path = path if kind == "zarr-zip" else None
        if kind == "zarr-zip":
            self._store = zarr.storage.ZipStore(path, mode="w")
        else:
            self._store = zarr.storage.LocalStore(path)
        # Attributes go in at creation: a later update appends a second zarr.json to a zip.
        self._group = zarr.create_group(store=self._store, attributes=root_attrs, zarr_format=3)

    def create(self, name: str, shape: tuple[int, ...], dtype: np.dtype[Any],
               chunks: tuple[int, ...], sha256: str) -> Any:
        is_text = dtype == np.dtype(object)  # a string array: variable-length UTF-8
        return self._group.create_array(
            name,
            shape=shape,
            dtype=str if is_text else dtype,
            chunks=tuple(max(1, c) for c in chunks),
            compressors=self._codec,
            fill_value="" if is_text else 0,
            attributes={"sha256": sha256},
            # Every chunk is stored, even all zeros: a reader can then tell a
            # deleted chunk (an error) from an empty one (see check_chunks).
            config={"write_empty_chunks": True},
        )

    def close(self) -> None:
        """Close the store once no write is in flight (after a failed one, others may be)."""
        wait_for_writes()
        self._store.close()
        if self._zip_path is not None:
            _normalise_zip(self._zip_path)


_SETTLE_SECONDS = 120.0


def wait_for_writes() -> None:
    """Wait until zarr's event loop runs no task, and collect their errors.

    zarr writes the chunks of one assignment concurrently; when one write
    fails (a full disk), the assignment raises at once while the others
    still run in zarr's I/O thread. Removing the folder then would race them
    (a late write re-creates it) and their errors would be printed as
    "Future exception was never retrieved" at exit.
    """
    from zarr.core import sync

    loop = getattr(sync, "loop", [None])[0]
    if loop is None or not loop.is_running():
        return

    async def settle() -> None:
        current = asyncio.current_task()
        while pending := [task for task in asyncio.all_tasks() if task is not current]:
            await asyncio.gather(*pending, return_exceptions=True)

    try:
        asyncio.run_coroutine_threadsafe(settle(), loop).result(timeout=_SETTLE_SECONDS)
    except concurrent.futures.TimeoutError:
        return


def _normalise_zip(path: Path) -> None:
    """Rewrite a zip with sorted entries and fixed timestamps.

    zarr stamps every entry with the time of writing, so two writes of the
    same data would differ byte for byte and so would a release's SHA256SUMS.
    Chunks are already compressed; entries stay stored uncompressed.
    """
    rewritten = path.with_name(path.name + ".normalised")
    with zipfile.ZipFile(path) as source, zipfile.ZipFile(rewritten, "w") as target:
        for name in sorted(source.namelist()):
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_STORED
            info.external_attr = 0o644 << 16
            target.writestr(info, source.read(name))
    os.replace(rewritten, path)


def open_zarr(zarr: Any, path: Path, kind: str) -> tuple[Any, Any, dict[str, Any], list[str]]:
    if kind == "zarr-zip":
        # Check the zip first: zarr 3.1's ZipStore.close() raises AttributeError
        # after a failed open, which would hide the real error.
        with zipfile.ZipFile(path):
            pass
        store = zarr.storage.ZipStore(path, mode="r")
    else:
        store = zarr.storage.LocalStore(path, read_only=True)
    is_open = False
    try:
        group = zarr.open_group(store=store, mode="r", zarr_format=3)
        attrs = dict(group.attrs)
        names = sorted(group.array_keys())
        is_open = True
    finally:
        if not is_open:
            store.close()
    return group, store, attrs, names


def _stored_keys(reader: Any) -> set[str]:
    """Every key (``array/c/0/0``) of a Zarr directory or zip store."""
    if reader.kind == "zarr-zip":
        with zipfile.ZipFile(reader.path) as archive:
            return set(archive.namelist())
    keys: set[str] = set()
    for folder, _, files in os.walk(reader.path):
        relative = Path(folder).relative_to(reader.path).as_posix()
        keys.update(name if relative == "." else f"{relative}/{name}" for name in files)
    return keys


def check_chunks(reader: Any) -> None:
    """Refuse a Zarr store with a missing chunk, which zarr would read as zeros.

    The writer stores every chunk (``write_empty_chunks``), so a missing one
    was deleted or lost. A store from an older writer, which skipped all-zero
    chunks, passes when the array's content still matches its ``sha256``
    attribute (hashed only then).

    Raises
    ------
    VerificationError
        Naming the array, the chunk and the models it holds.
    """
    if reader.kind == "hdf5":
        return  # HDF5 chunks live inside one file; damage shows as a read error
    keys = _stored_keys(reader)
    for name in reader.array_names():
        array = reader.array(name)
        if not array.shape or 0 in array.shape:
            continue
        grid = [range(count) for count in array.cdata_shape]
        missing = [
            coords
            for coords in itertools.product(*grid)
            if f"{name}/{array.metadata.encode_chunk_key(coords)}" not in keys
        ]
        if not missing or array_sha256(array) == reader.stored_sha256(name):
            continue
        key = array.metadata.encode_chunk_key(missing[0])
        first_row = missing[0][0] * array.chunks[0]
        more = f" (and {len(missing) - 1} more chunks)" if len(missing) > 1 else ""
        raise VerificationError(
            f"{reader.path.name}: array {name!r} chunk {key} is missing{more}, "
            f"{reader.models_of_rows(name, first_row, first_row + array.chunks[0])}; "
            "it would read as zeros (run vptool verify)"
        )
