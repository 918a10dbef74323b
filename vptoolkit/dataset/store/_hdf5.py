"""The HDF5 container of a dataset store: ``*.h5`` and ``*.hdf5`` files.

Owns writing (:class:`Hdf5Sink`, gzip level 4 with shuffle) and opening for
reading (:func:`open_hdf5`). A root attribute that is a ``str``, ``bool``,
``int`` or ``float``, or a non-empty list of scalars of one of these types, is
stored as HDF5 holds it (a list as a 1-D array, strings as UTF-8). HDF5 cannot
hold nested attributes, so every other one is stored as a JSON string and the
root attribute ``json_attributes``
(:data:`~vptoolkit.dataset.store.schema.HDF5_JSON_KEY`) names those keys; reading
decodes them. ``h5py`` is imported inside the functions, and
:mod:`vptoolkit.dataset.store.writer` and :mod:`vptoolkit.dataset.store.reader` import
this module only to write or open an HDF5 store.

HDF5 cannot recover from a failed write: closing such a file fails again and
the library crashes when the interpreter exits. So the sink writes through
:class:`_KeptErrorFile`, which keeps the first failed write (a full disk, a
file over ``ulimit -f``) instead of handing it to HDF5 and drops the rest; the
next array write and :meth:`Hdf5Sink.close` raise it as the ``OSError`` it is,
after the file is closed once.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from vptoolkit.checks import one_line
from vptoolkit.dataset.store.schema import HDF5_JSON_KEY
from vptoolkit.errors import InputError, VerificationError
from vptoolkit.files import parse_json
from vptoolkit.optional import require

__all__ = ["Hdf5Sink", "open_hdf5"]


class _KeptErrorFile:
    """The file under an HDF5 file being written, as h5py's ``fileobj`` driver calls it.

    Writes and truncations go straight to the file (unbuffered) until one
    fails; that ``OSError`` is kept in :attr:`error` and every later write or
    truncation is dropped while reporting success, so HDF5 never sees an error.
    """

    def __init__(self, path: Path) -> None:
        self._stream = open(path, "w+b", buffering=0)  # closed by close()
        self.error: OSError | None = None

    def seek(self, offset: int, whence: int = 0) -> int:
        return self._stream.seek(offset, whence)

    def tell(self) -> int:
        return self._stream.tell()

    def read(self, size: int = -1) -> bytes:
        """Read ``size`` bytes (h5py takes an object with ``read`` and ``seek`` for a file)."""
        return self._stream.read(size) or b""

    def readinto(self, buffer: bytearray | memoryview) -> int | None:
        return self._stream.readinto(buffer)

    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data).cast("B")
        written = 0
        try:
            while self.error is None and written < len(view):
                written += self._stream.write(view[written:]) or 0
        except OSError as err:
            self.error = err
        return len(view)

    def truncate(self, size: int | None = None) -> int:
        try:
            if self.error is None:
                return self._stream.truncate(size)
        except OSError as err:
            self.error = err
        return self._stream.tell() if size is None else size

    def flush(self) -> None:
        """Nothing to flush: writes are unbuffered."""

    def raise_error(self) -> None:
        """Raise the kept error, if a write failed."""
        if self.error is not None:
            raise self.error

    def close(self) -> None:
        try:
            self._stream.close()
        except OSError as err:
            self.error = self.error or err


class _Hdf5Array:
    """An HDF5 dataset being written: an assignment raises the file's kept write error.

    Any other attribute is the dataset's own.
    """

    def __init__(self, dataset: Any, stream: _KeptErrorFile) -> None:
        self._dataset = dataset
        self._stream = stream

    def __setitem__(self, key: Any, value: Any) -> None:
        self._dataset[key] = value
        self._stream.raise_error()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._dataset, name)


class Hdf5Sink:
    """Writes the layout to an HDF5 file.

    Raises
    ------
    OSError
        From an array assignment or :meth:`close`, when writing the file
        failed (a full disk, a file too large); closing still closes the file.
    """

    def __init__(self, path: Path, root_attrs: dict[str, Any]) -> None:
        h5py = require("h5py")  # a core dependency
        self._h5py = h5py
        self._stream = _KeptErrorFile(path)
        try:
            self._file = h5py.File(self._stream, "w", track_order=True)
        except BaseException:
            self._stream.close()
            raise
        json_keys = []
        for key, value in root_attrs.items():
            if _is_scalar(value):
                self._file.attrs[key] = value
            elif _is_plain_list(value):
                self._file.attrs[key] = (np.array(value, dtype=h5py.string_dtype())
                                         if isinstance(value[0], str) else value)
            else:
                self._file.attrs[key] = json.dumps(value, ensure_ascii=False)
                json_keys.append(key)
        self._file.attrs[HDF5_JSON_KEY] = json.dumps(json_keys)

    def create(self, name: str, shape: tuple[int, ...], dtype: np.dtype[Any],
               chunks: tuple[int, ...], sha256: str) -> Any:
        if dtype == np.dtype(object):  # a string array: variable-length UTF-8
            dtype = self._h5py.string_dtype()
        if 0 in shape:
            # HDF5 cannot chunk an empty dimension; an empty dataset needs no compression.
            dataset = self._file.create_dataset(name, shape=shape, dtype=dtype)
        else:
            dataset = self._file.create_dataset(
                name,
                shape=shape,
                dtype=dtype,
                chunks=tuple(min(max(1, c), s) for c, s in zip(chunks, shape)),
                compression="gzip",
                compression_opts=4,
                shuffle=True,
            )
        dataset.attrs["sha256"] = sha256
        return _Hdf5Array(dataset, self._stream)

    def close(self) -> None:
        """Close the HDF5 file and the file under it, then raise a write error kept meanwhile."""
        try:
            self._file.close()
        finally:
            self._stream.close()
        self._stream.raise_error()


def _is_scalar(value: Any) -> bool:
    int64 = np.iinfo(np.int64)
    return isinstance(value, (str, bool, float)) or (
        isinstance(value, int) and int64.min <= value <= int64.max
    )


def _is_plain_list(value: Any) -> bool:
    """A non-empty list of scalars of one type, which HDF5 holds as a 1-D attribute."""
    if not isinstance(value, list) or not value or not all(_is_scalar(item) for item in value):
        return False
    return len({type(item) for item in value}) == 1


def open_hdf5(path: Path, stream: BinaryIO | io.RawIOBase | None = None,
              ) -> tuple[Any, Any, dict[str, Any], list[str]]:
    """Open ``path`` for reading, or the readable, seekable ``stream`` that holds it.

    Raises
    ------
    OSError
        From h5py, when the file is not HDF5 at all.
    VerificationError
        When the file opens but its root attributes or links cannot be read:
        libhdf5 raises ``RuntimeError`` (``incorrect metadata checksum``) or
        ``OSError`` for a damaged object header, attribute or link block.
    """
    h5py = require("h5py")  # a core dependency
    handle = h5py.File(path if stream is None else stream, "r")
    is_open = False
    try:
        try:
            raw = dict(handle.attrs)
            nodes = list(handle.items())
        except (RuntimeError, OSError, KeyError, ValueError) as err:
            raise _damaged(path, err) from err
        json_keys = parse_json(raw.pop(HDF5_JSON_KEY, "[]"), f"{path.name}: {HDF5_JSON_KEY}")
        if not isinstance(json_keys, list) or not all(isinstance(key, str) for key in json_keys):
            raise InputError(f"{path.name}: {HDF5_JSON_KEY} is not a list of names")
        attrs = {}
        for key, value in raw.items():
            if key in json_keys:
                attrs[key] = parse_json(value, f"{path.name}: attribute {key}")
            elif isinstance(value, bytes):
                attrs[key] = value.decode("utf-8")
            elif isinstance(value, (np.generic, np.ndarray)):
                attrs[key] = [item.decode("utf-8") if isinstance(item, bytes) else item
                              for item in value.tolist()] if value.ndim else value.tolist()
            else:
                attrs[key] = value
        names = sorted(key for key, node in nodes if isinstance(node, h5py.Dataset))
        is_open = True
    finally:
        if not is_open:
            handle.close()
    return handle, handle, attrs, names


def _damaged(path: Path, error: BaseException) -> VerificationError:
    """The one-line error for an HDF5 store whose metadata (a header, attribute or link block)
    is damaged."""
    return VerificationError(f"{path.name}: the HDF5 metadata cannot be read ({one_line(error)}); "
                             "the store is damaged (run vptool verify)")
