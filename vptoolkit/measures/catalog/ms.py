"""MS, mesh saliency: how much salient surface a view shows.

``MS(v) = sum_z [a_z(v) > 0] S(z)``,

the sum of the mesh saliency ``S(z)`` of Lee, Varshney and Jacobs over the
faces the view sees (:func:`vptoolkit.measures.saliency.mesh_saliency`:
centre-surround differences of the Gaussian-weighted mean curvature at five
scales, each after Itti's normalisation). Lee et al. sum the saliency of the
surface points a view sees, here the faces (their centroids carry the
saliency), each once whatever its pixels. Higher is better (Lee et al.
choose the view that maximises it). A view that sees nothing: NaN (not 0,
which would tie it with the seen views of a mesh without saliency).

This is the survey's measure that quoniam does not implement.

Source: Lee, Varshney and Jacobs (2005), "Mesh saliency"; survey of
Bonaventura et al. (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure
from vptoolkit.measures.saliency import mesh_saliency


def _compute(data: ViewData) -> NDArray[np.float64]:
    _, faces, _ = data.entries
    return np.where(data.seen, data.per_view(mesh_saliency(data)[faces]), np.nan)


MEASURE = Measure(
    name="MS",
    title="mesh saliency",
    family="surface",
    higher_is_better=True,
    needs=frozenset({"pixels", "saliency", "curvature"}),
    compute=_compute,
    source="Lee, Varshney and Jacobs (2005)",
)
