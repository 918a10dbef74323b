"""A lazy sequence of stored models: each made when it is read, none kept."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import overload

import numpy as np

from vptoolkit.dataset.store.schema import ModelEntry
from vptoolkit.errors import InputError

__all__ = ["LazyEntries"]


class LazyEntries(Sequence[ModelEntry]):
    """Models made on access: a sequence of :class:`ModelEntry` that holds none of them.

    ``entries[i]`` calls ``get(i)`` every time it is read, so
    :func:`~vptoolkit.dataset.store.writer.write_dataset`, which reads each
    entry twice, holds one model at a time whatever the store's size.
    :meth:`~vptoolkit.dataset.store.reader.StoreReader.entries` gives a store's
    models so; a build's staged files, a release's models and the paper
    authors' tree are read through one too.

    Parameters
    ----------
    length : int
        Number of models, at least 0.
    get : callable
        ``get(i)`` makes model ``i``, for ``0 <= i < length`` (a negative
        index is turned into that range first).

    Raises
    ------
    InputError
        If ``length`` is not a whole number of at least 0.

    Examples
    --------
    >>> entries = LazyEntries(3, lambda i: f"model {i}")  # a text stands in for a ModelEntry
    >>> len(entries), entries[-1], list(entries[1:])
    (3, 'model 2', ['model 1', 'model 2'])
    """

    def __init__(self, length: int, get: Callable[[int], ModelEntry]) -> None:
        if isinstance(length, bool) or not isinstance(length, (int, np.integer)) or length < 0:
            raise InputError(f"length: expected a whole number >= 0, got {length!r}")
        self._length = int(length)
        self._get = get

    def __len__(self) -> int:
        return self._length

    @overload
    def __getitem__(self, index: int) -> ModelEntry: ...

    @overload
    def __getitem__(self, index: slice) -> LazyEntries: ...

    def __getitem__(self, index: int | slice) -> ModelEntry | LazyEntries:
        if isinstance(index, slice):
            rows = range(self._length)[index]
            return LazyEntries(len(rows), lambda position: self._get(rows[position]))
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise TypeError(f"entries: index must be an integer or a slice, got {index!r}")
        if not -self._length <= index < self._length:
            raise IndexError(f"index {index} out of range for {self._length} models")
        return self._get(int(index) % self._length)
