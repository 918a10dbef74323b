"""VE, viewpoint entropy.

``VE(v) = -sum_z p(z|v) log2 p(z|v)`` with ``p(z|v) = a_z(v) / a_t(v)`` (paper eq. 1).
Higher is better. A view that sees nothing: NaN.

Source: Vázquez, Feixas, Sbert and Heidrich (2001).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._paper import paper_column
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return paper_column(data, "VE")


MEASURE = Measure(
    name="VE",
    title="viewpoint entropy",
    family="area",
    higher_is_better=True,
    needs=frozenset({"sums"}),
    compute=_compute,
    source="Vázquez, Feixas, Sbert and Heidrich (2001)",
)
