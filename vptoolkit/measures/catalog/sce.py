"""SCE, silhouette curvature extrema.

``SCE(v) = (1 / N) sum_i (|alpha_i| / 90)^2`` over the ``N`` contour pixels
of the view, ``alpha_i`` the turning angle at pixel ``i`` in degrees (a
multiple of 45, see :mod:`vptoolkit.measures.catalog._silhouette`): squaring
weights the sharp turns (the curvature extrema) above the gentle ones, from
0 (straight contours) to 4 (reversals only). Higher is better (quoniam's
``SilhouetteCurvatureExtrema``: maximum best). A view that sees nothing: NaN.

Source: Secord, Lu, Finkelstein, Singh and Nealen (2011), as reviewed by
Bonaventura, Feixas, Sbert, Chuang and Wallraven (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._silhouette import mean_bend
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return mean_bend(data, 2.0)


MEASURE = Measure(
    name="SCE",
    title="silhouette curvature extrema",
    family="silhouette",
    higher_is_better=True,
    needs=frozenset({"silhouette"}),
    compute=_compute,
    source="Secord, Lu, Finkelstein, Singh and Nealen (2011)",
)
