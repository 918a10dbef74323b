"""SC, silhouette curvature.

``SC(v) = (1 / N) sum_i |alpha_i| / 90`` over the ``N`` contour pixels of
the view, ``alpha_i`` the turning angle at pixel ``i`` in degrees (a
multiple of 45, see :mod:`vptoolkit.measures.catalog._silhouette`): the mean
bend in right angles, from 0 (straight contours) to 2 (reversals only).
Higher is better (quoniam's ``SilhouetteCurvature``: maximum best). A view
that sees nothing: NaN.

Source: Vieira, Bordignon, Peixoto, Tavares, Lopes, Velho and Lewiner
(2009), as reviewed by Bonaventura, Feixas, Sbert, Chuang and Wallraven (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._silhouette import mean_bend
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return mean_bend(data, 1.0)


MEASURE = Measure(
    name="SC",
    title="silhouette curvature",
    family="silhouette",
    higher_is_better=True,
    needs=frozenset({"silhouette"}),
    compute=_compute,
    source="Vieira, Bordignon, Peixoto, Tavares, Lopes, Velho and Lewiner (2009)",
)
