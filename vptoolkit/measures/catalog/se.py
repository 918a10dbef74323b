"""SE, silhouette entropy.

``SE(v) = -sum_b p_b log2 p_b`` with ``p_b`` the share of the view's
contour pixels whose turning angle falls in bin ``b`` of the 9-bin
turning-angle histogram (45-degree bins over (-180, 180], see
:mod:`vptoolkit.measures.catalog._silhouette`), in bits: 0 when every
contour pixel turns by the same angle, ``log2 k`` when the angles spread
evenly over ``k`` bins (at most ``log2 8 = 3``, bin -180 staying empty).
Higher is better (quoniam's ``SilhouetteEntropy``: maximum best). A view
that sees nothing: NaN.

quoniam takes the angle of a reversal from ``glm::orientedAngle``, which
may give -180 (bin 0) or +180 (bin 8); here a reversal is always +180.

Source: Page, Koschan, Sukumar, Roui-Abidi and Abidi (2003), as reviewed by
Bonaventura, Feixas, Sbert, Chuang and Wallraven (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._histograms import entropies
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return entropies(data.features.turning_histogram)


MEASURE = Measure(
    name="SE",
    title="silhouette entropy",
    family="silhouette",
    higher_is_better=True,
    needs=frozenset({"silhouette"}),
    compute=_compute,
    source="Page, Koschan, Sukumar, Roui-Abidi and Abidi (2003)",
)
