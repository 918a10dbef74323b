"""The paper's four measures (VE, VR, VKL, VMI) computed together, once per set of views.

They come from :func:`vptoolkit.measures.sums.quality_from_histograms`, the
same streaming computation as the measuring session uses for them, so the four
keep the same values whatever else is asked for.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.data import ViewData
from vptoolkit.measures.sums import PAPER_COLUMNS, quality_from_histograms


def paper_column(data: ViewData, name: str) -> NDArray[np.float64]:
    """Raw values of one of the paper's four measures, ``(n_views,)``."""
    if "paper" not in data.cache:
        data.cache["paper"] = quality_from_histograms(
            data.histograms, data.areas, n_views=data.n_views, recompute=data.histograms)
    raw: NDArray[np.float64] = data.cache["paper"]
    return raw[:, PAPER_COLUMNS.index(name)]
