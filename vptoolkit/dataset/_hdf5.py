"""The HDF5 container of a dataset store: ``*.h5`` and ``*.hdf5`` files.

Owns writing (:class:`Hdf5Sink`, gzip level 4 with shuffle) and opening for
reading (:func:`open_hdf5`). A root attribute that is a ``str``, ``bool``,
``int`` or ``float``, or a non-empty list of scalars of one of these types, is
stored as HDF5 holds it (a list as a 1-D array, strings as UTF-8). HDF5 cannot
hold nested attributes, so every other one is stored as a JSON string and the
root attribute ``json_attributes``
(:data:`~vptoolkit.dataset.schema.HDF5_JSON_KEY`) names those keys; reading
decodes them. ``h5py`` is imported inside the functions, and
:mod:`vptoolkit.dataset.writer` and :mod:`vptoolkit.dataset.reader` import
this module only to write or open an HDF5 store.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from vptoolkit.dataset.schema import HDF5_JSON_KEY
from vptoolkit.errors import InputError
from vptoolkit.files import parse_json
from vptoolkit.optional import require

__all__ = ["Hdf5Sink", "open_hdf5"]


class Hdf5Sink:
    """Writes the layout to an HDF5 file."""

    def __init__(self, path: Path, root_attrs: dict[str, Any]) -> None:
        h5py = require("h5py")  # a core dependency
        self._h5py = h5py
        self._file = h5py.File(path, "w", track_order=True)
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
        return dataset

    def close(self) -> None:
        self._file.close()


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


def open_hdf5(path: Path) -> tuple[Any, Any, dict[str, Any], list[str]]:
    h5py = require("h5py")  # a core dependency
    handle = h5py.File(path, "r")
    is_open = False
    try:
        raw = dict(handle.attrs)
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
        names = sorted(key for key, node in handle.items() if isinstance(node, h5py.Dataset))
        is_open = True
    finally:
        if not is_open:
            handle.close()
    return handle, handle, attrs, names
