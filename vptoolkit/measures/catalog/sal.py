"""SAL, viewpoint saliency: how much of the salient surface a view holds.

``SAL(v) = sum_z p(v|z) S(z)``, ``p(v|z) = a_z(v) / A_z``, ``A_z = sum_v a_z(v)``,

the saliency ``S(z)`` of each face (Feixas et al.'s polygonal saliency, the
mean Jensen-Shannon divergence between the view distributions of the face
and of its edge neighbours, :func:`vptoolkit.measures.saliency.polygon_saliency`)
weighted by the share of the face's pixels over all views that this view
holds. A seen face without saliency (none of its edge neighbours is seen)
gets the lowest saliency of the others, as quoniam's ``FeixasSaliency``
gives it. Higher is better (quoniam: maximum best). A view that sees
nothing: NaN.

quoniam joins a face to every face that shares a vertex with it, itself
included (a zero divergence counted in the mean); here the neighbours are
the faces that share an edge.

Source: Feixas, Sbert and González (2009), "A unified information-theoretic
framework for viewpoint selection and mesh saliency"; survey of Bonaventura
et al. (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure
from vptoolkit.measures.saliency import polygon_saliency


def _compute(data: ViewData) -> NDArray[np.float64]:
    _, faces, counts = data.entries
    saliency = polygon_saliency(data, undefined="lowest")
    values = data.per_view(counts / data.face_totals[faces] * saliency[faces])
    return np.where(data.seen, values, np.nan)


MEASURE = Measure(
    name="SAL",
    title="viewpoint saliency",
    family="surface",
    higher_is_better=True,
    needs=frozenset({"pixels", "saliency"}),
    compute=_compute,
    source="Feixas, Sbert and González (2009)",
)
