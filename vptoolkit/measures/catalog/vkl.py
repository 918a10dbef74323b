"""VKL, viewpoint Kullback-Leibler divergence.

``VKL(v) = sum_z p(z|v) log2(p(z|v) A_t / A_z)`` (paper eq. 3).
Lower is better. A view that sees nothing: NaN.

Source: Sbert, Plemenos, Feixas and González (2005).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._paper import paper_column
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return paper_column(data, "VKL")


MEASURE = Measure(
    name="VKL",
    title="viewpoint Kullback-Leibler divergence",
    family="area",
    higher_is_better=False,
    needs=frozenset({"sums"}),
    compute=_compute,
    source="Sbert, Plemenos, Feixas and González (2005)",
)
