"""VMI, viewpoint mutual information (I1).

``VMI(v) = sum_z p(z|v) log2(p(z|v) / p(z))`` with ``p(z) = sum_v a_z(v) / sum_v a_t(v)``
over the sampled views (paper eq. 4). Lower is better. A view that sees nothing: NaN.

Source: Feixas, Sbert and González (2009).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._paper import paper_column
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return paper_column(data, "VMI")


MEASURE = Measure(
    name="VMI",
    title="viewpoint mutual information",
    family="information",
    higher_is_better=False,
    needs=frozenset({"sums"}),
    compute=_compute,
    source="Feixas, Sbert and González (2009)",
)
