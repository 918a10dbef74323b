"""MD, maximum depth.

``MD(v) = max`` over the view's covered pixels of the normalised depth
``(t - near) / (far - near)`` (:mod:`vptoolkit.visibility.features`: 0 at
the nearest point the model can reach, 1 at the farthest), so a view that
looks deep into the model scores high. Higher is better (quoniam's
``MaximumDepth``: maximum best). A view that sees nothing: NaN.

quoniam reads the maximum of the 8-bit OpenGL depth buffer, divided by 255,
which is not linear in the distance; ours is linear in the distance along
the camera axis and does not depend on the camera's clipping planes.

Source: Stoev and Strasser (2002), as reviewed by Bonaventura, Feixas,
Sbert, Chuang and Wallraven (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    return np.array(data.features.max_depth, dtype=np.float64)


MEASURE = Measure(
    name="MD",
    title="maximum depth",
    family="depth",
    higher_is_better=True,
    needs=frozenset({"depth"}),
    compute=_compute,
    source="Stoev and Strasser (2002)",
)
