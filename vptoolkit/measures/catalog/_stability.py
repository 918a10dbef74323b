"""What the stability measures (INS, DVS) share: each view against its nearest views.

A stability measure compares a view with its neighbouring views on the
sphere (:meth:`~vptoolkit.measures.data.ViewData.neighbours`). The
comparisons are symmetric, so each unordered pair of neighbouring views is
compared once, however many of the two views list the other among their
nearest.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.data import ViewData


def neighbour_pairs(data: ViewData, count: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The distinct pairs of a view and one of its ``count`` nearest views.

    Returns
    -------
    pairs : (n_pairs, 2) int64
        View indices ``(i, j)`` with ``i < j``, each unordered pair once.
    slots : (n_views, k) int64
        ``slots[v, m]``: the row of ``pairs`` that joins view ``v`` and its
        ``m``-th nearest view (``k = min(count, n_views - 1)``).
    """
    neighbours = data.neighbours(count)
    n_views, k = neighbours.shape
    rows = np.repeat(np.arange(n_views, dtype=np.int64), k)
    columns = neighbours.ravel()
    keys = np.minimum(rows, columns) * n_views + np.maximum(rows, columns)
    unique, inverse = np.unique(keys, return_inverse=True)
    pairs = np.stack([unique // n_views, unique % n_views], axis=1).astype(np.int64)
    return pairs, inverse.reshape(n_views, k).astype(np.int64)


def both_seen(data: ViewData, pairs: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Pairs whose two views both see some face, ``(n_pairs,) bool``."""
    return np.asarray(data.seen[pairs[:, 0]] & data.seen[pairs[:, 1]], dtype=np.bool_)
