"""SS, the Stoev and Strasser measure: projected area balanced against depth.

``SS(v) = (p_v + d_v + 1 - |d_v - p_v|) / 3 = (1 + 2 min(p_v, d_v)) / 3``

with ``d_v`` the view's maximum normalised depth (MD) and ``p_v`` its
normalised projected area

``p_v = a_t(v) / max_v' a_t(v')``,

the covered pixels relative to the view of the drawn set that covers the
most, so both terms run over [0, 1] and SS over [1/3, 1]: a view scores
high only if it shows both a large area and a deep scene. Higher is better
(quoniam's ``StoevStrasser``: maximum best). A view that sees nothing: NaN.

quoniam takes ``p_v = a_t(v) / sum_v' a_t(v')``, the view's share of all
projected area, which is about ``1 / n_views`` (0.001 for 1000 views), so
there ``min(p_v, d_v) = p_v`` for nearly every view and the measure ranks
views by projected area alone. Normalising by the largest projected area
instead keeps the balance the formula was made for.

Source: Stoev and Strasser (2002), as reviewed by Bonaventura, Feixas,
Sbert, Chuang and Wallraven (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    projected = data.projected
    largest = projected.max(initial=0.0)
    area = np.divide(projected, largest, out=np.full_like(projected, np.nan), where=largest > 0)
    depth = data.features.max_depth
    return (area + depth + 1.0 - np.abs(depth - area)) / 3.0


MEASURE = Measure(
    name="SS",
    title="Stoev and Strasser",
    family="depth",
    higher_is_better=True,
    needs=frozenset({"pixels", "depth"}),
    compute=_compute,
    source="Stoev and Strasser (2002)",
)
