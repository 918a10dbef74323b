"""HM, Plemenos and Benayada's heuristic measure.

``HM(v) = (1 / N_z) sum_z ceil(a_z(v) / (a_z(v) + 1)) + a_t(v) / R^2``: the
fraction of the mesh's ``N_z`` faces that are visible (:mod:`.nvt` over
``N_z``) plus the fraction of the ``R x R`` image the model covers
(:mod:`.pa`), each in [0, 1], so ``HM`` lies in [0, 2]. Plemenos and
Benayada's ceiling makes each face count 1 once it has a pixel, as
quoniam's ``HeuristicMeasure`` computes it. Higher is better. A view that
sees nothing: 0.

Source: Plemenos and Benayada (1996); survey of Bonaventura et al. (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog.nvt import MEASURE as NVT
from vptoolkit.measures.catalog.pa import MEASURE as PA
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return NVT.compute(data) / data.n_faces + PA.compute(data)


MEASURE = Measure(
    name="HM",
    title="heuristic measure",
    family="area",
    higher_is_better=True,
    needs=frozenset({"pixels"}),
    compute=_compute,
    source="Plemenos and Benayada (1996)",
)
