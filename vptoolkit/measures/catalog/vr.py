"""VR, visibility ratio.

``VR(v) = sum_z [a_z(v) > 0] A_z / A_t`` (paper eq. 2), the fraction of the surface seen.
Higher is better. A view that sees nothing: 0.

Source: Plemenos and Benayada (1996).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._paper import paper_column
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return paper_column(data, "VR")


MEASURE = Measure(
    name="VR",
    title="visibility ratio",
    family="area",
    higher_is_better=True,
    needs=frozenset({"sums"}),
    compute=_compute,
    source="Plemenos and Benayada (1996)",
)
