"""SL, silhouette length.

``SL(v)`` is the length of all silhouette contours of the view (outer and
inner), in pixels of the ``settings.resolution`` image: 1 per axis step and
``sqrt(2)`` per diagonal step of the 8-connected chain, each contour closed
(:mod:`vptoolkit.visibility.features`), as quoniam sums ``cv::arcLength``
over the contours. Higher is better (quoniam's ``SilhouetteLength``: maximum
best). A view that sees nothing: NaN.

Source: Polonsky, Patanè, Biasotti, Gotsman and Spagnuolo (2005), as
reviewed by Bonaventura, Feixas, Sbert, Chuang and Wallraven (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._silhouette import has_silhouette
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return np.where(has_silhouette(data), data.features.silhouette_length, np.nan)


MEASURE = Measure(
    name="SL",
    title="silhouette length",
    family="silhouette",
    higher_is_better=True,
    needs=frozenset({"silhouette"}),
    compute=_compute,
    source="Polonsky, Patanè, Biasotti, Gotsman and Spagnuolo (2005)",
)
