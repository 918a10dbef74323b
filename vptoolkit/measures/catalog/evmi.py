"""EVMI, saliency-based extended viewpoint mutual information.

``EVMI(v) = sum_z p(z|v) log2(p(z|v) / p'(z))``, ``p(z|v) = a_z(v) / a_t(v)``,
``p'(z) = S(z) A_z / sum_y S(y) A_y``, ``A_z = sum_v a_z(v)``:

VMI (:mod:`.vmi`) with the face distribution ``p(z)`` replaced by the
saliency-weighted one ``p'(z)``, ``S(z)`` Feixas et al.'s polygonal
saliency (:func:`vptoolkit.measures.saliency.polygon_saliency`). A view
close to ``p'`` shows the surface in proportion to how salient it is. As in
quoniam's ``SaliencyEVMI``, a seen face without saliency (none of its edge
neighbours is seen) gets the highest saliency of the others, and faces of
zero saliency (``p'(z) = 0``) are left out of the sum rather than making it
infinite. Lower is better (quoniam: maximum not best; the survey: the
best view minimises it). A view that sees nothing: NaN.

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
    views, faces, counts = data.entries
    importance = polygon_saliency(data, undefined="highest") * data.face_totals
    weight = importance[faces]
    salient = weight > 0
    p_view = counts / data.projected[views]
    terms = p_view * importance.sum()
    np.divide(terms, weight, out=terms, where=salient)
    terms[~salient] = 1.0  # log2 1 = 0: a face of no saliency adds nothing
    np.log2(terms, out=terms)
    terms *= p_view
    values = data.per_view(terms)
    return np.where(data.seen, values, np.nan)


MEASURE = Measure(
    name="EVMI",
    title="saliency-based extended viewpoint mutual information",
    family="surface",
    higher_is_better=False,
    needs=frozenset({"pixels", "saliency"}),
    compute=_compute,
    source="Feixas, Sbert and González (2009)",
)
