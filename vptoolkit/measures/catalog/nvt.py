"""NVT, number of visible triangles.

``NVT(v) = sum_z [a_z(v) > 0]``, the number of faces with at least one pixel
in the view (back faces culled, occluded faces unseen). Higher is better. A
view that sees nothing: 0.

Source: Plemenos and Benayada (1996), as quoniam's ``NumberOfVisibleTriangles``
and the survey of Bonaventura et al. (2018) take it.
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return np.diff(data.view_starts).astype(np.float64)


MEASURE = Measure(
    name="NVT",
    title="number of visible triangles",
    family="area",
    higher_is_better=True,
    needs=frozenset({"pixels"}),
    compute=_compute,
    source="Plemenos and Benayada (1996)",
)
