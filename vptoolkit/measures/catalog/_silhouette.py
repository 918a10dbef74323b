"""What the silhouette measures share: which views have a silhouette, and its turning angles.

The turning angles of a view are those of :class:`~vptoolkit.visibility.features.ViewFeatures`:
at every pixel of every contour, the signed angle between the chain step
into it and the step out of it, a multiple of 45 degrees in (-180, 180],
counted in ``TURNING_BINS`` bins, bin ``b = (angle + 180) // 45``. So bin
``b`` holds exactly the angle ``45 b - 180`` degrees (:data:`TURNING_ANGLES_DEG`);
bin 0 (-180) stays empty, a reversal being +180 (bin 8).

A view that sees nothing has no contour and no angle; a view that sees
anything has at least one (an isolated pixel contributes one angle of 0).
"""

from __future__ import annotations

from typing import Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._histograms import distributions
from vptoolkit.measures.data import ViewData
from vptoolkit.visibility.features import TURNING_BINS

TURNING_ANGLES_DEG: Final = 45.0 * np.arange(TURNING_BINS, dtype=np.float64) - 180.0
"""The turning angle of each bin of the turning-angle histogram, in degrees, ``(TURNING_BINS,)``."""


def has_silhouette(data: ViewData) -> NDArray[np.bool_]:
    """Views whose image has at least one contour pixel, ``(n_views,) bool``."""
    counts = data.features.turning_histogram
    has: NDArray[np.bool_] = counts.sum(axis=1) > 0
    return has


def mean_bend(data: ViewData, power: float) -> NDArray[np.float64]:
    """Mean of ``(|angle| / 90)^power`` over all contour pixels of each view.

    Parameters
    ----------
    data : ViewData
        Views drawn with silhouette statistics.
    power : float
        1 for the mean bend (SC), 2 for the mean squared bend (SCE).

    Returns
    -------
    bend : (n_views,) float64
        ``sum_b p_b (|45 b - 180| / 90)^power`` with ``p_b`` the share of
        the view's angles in bin ``b``: 0 for straight contours, up to
        ``2^power`` for reversals; NaN for a view without silhouette.
    """
    shares = distributions(data.features.turning_histogram)
    bend: NDArray[np.float64] = shares @ (np.abs(TURNING_ANGLES_DEG) / 90.0) ** power
    return bend
