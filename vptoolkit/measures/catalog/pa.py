"""PA, projected area.

``PA(v) = a_t(v) / R^2 = sum_z a_z(v) / R^2``, the fraction of the ``R x R``
image that the model covers (background excluded), so that values do not
depend on the image side (quoniam counts pixels, ``a_t(v)``; the order of
the views is the same). Higher is better. A view that sees nothing: 0.

Source: Plemenos and Benayada (1996); survey of Bonaventura et al. (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return data.projected / float(data.settings.resolution) ** 2


MEASURE = Measure(
    name="PA",
    title="projected area",
    family="area",
    higher_is_better=True,
    needs=frozenset({"pixels"}),
    compute=_compute,
    source="Plemenos and Benayada (1996)",
)
