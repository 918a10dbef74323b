"""DD, depth distribution.

``DD(v) = 1 - sum_b h_b(v)^2`` with ``h_b(v)`` the share of the view's
covered pixels in bin ``b`` of the 256-bin histogram of normalised depth
(:mod:`vptoolkit.visibility.features`): 0 when all of the seen surface lies
in one depth bin, ``1 - 1/k`` when it spreads evenly over ``k`` bins, so a
view that shows the model over a wide range of depths scores high. Higher
is better (quoniam's ``DepthDistribution``: maximum best). A view that sees
nothing: NaN.

quoniam bins the 8-bit OpenGL depth buffer (256 values, not linear in the
distance); ours bins the normalised depth, linear in the distance.

Source: Secord, Lu, Finkelstein, Singh and Nealen (2011), as reviewed by
Bonaventura, Feixas, Sbert, Chuang and Wallraven (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._histograms import distributions
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    shares = distributions(data.features.depth_histogram)
    return 1.0 - (shares**2).sum(axis=1)


MEASURE = Measure(
    name="DD",
    title="depth distribution",
    family="depth",
    higher_is_better=True,
    needs=frozenset({"depth"}),
    compute=_compute,
    source="Secord, Lu, Finkelstein, Singh and Nealen (2011)",
)
