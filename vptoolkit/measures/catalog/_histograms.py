"""What several measures share: per-view histograms turned into distributions and entropies.

Each row of a ``(n_views, n_bins)`` array of non-negative weights (pixel or
angle counts) is one view; a row that sums to 0 is a view that saw nothing,
and gets NaN.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def distributions(weights: ArrayLike) -> NDArray[np.float64]:
    """Each view's histogram divided by its sum.

    Parameters
    ----------
    weights : (n_views, n_bins) array_like
        Non-negative weights per bin.

    Returns
    -------
    probabilities : (n_views, n_bins) float64
        Rows summing to 1; rows of NaN where the weights sum to 0.
    """
    values = np.asarray(weights, dtype=np.float64)
    totals = values.sum(axis=1, keepdims=True)
    return np.divide(values, totals, out=np.full_like(values, np.nan), where=totals > 0)


def entropies(weights: ArrayLike) -> NDArray[np.float64]:
    """Shannon entropy of each view's histogram, in bits.

    ``H = -sum_b p_b log2 p_b`` with ``p_b`` the bin's share of the row
    (:func:`distributions`), ``0 log2 0 = 0``.

    Returns
    -------
    entropy : (n_views,) float64
        From 0 (one bin) to ``log2 n_bins`` (all bins equal); NaN where the
        row sums to 0.
    """
    probabilities = distributions(weights)
    logs = np.log2(probabilities, out=np.zeros_like(probabilities), where=probabilities > 0)
    entropy: NDArray[np.float64] = 0.0 - (probabilities * logs).sum(axis=1)  # NaN stays NaN
    return entropy
