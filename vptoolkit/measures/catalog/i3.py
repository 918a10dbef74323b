"""I3, viewpoint specific information weighted by the faces' own information.

``I3(v; Z) = sum_z p(z|v) I2(z; V)`` with ``p(z|v) = a_z(v) / a_t(v)`` and,
for each face, ``I2(z; V) = H(V) - H(V|z)``: ``H(V) = -sum_v p(v) log2 p(v)``
with ``p(v) = a_t(v) / sum_v' a_t(v')``, and ``H(V|z) = -sum_v p(v|z) log2
p(v|z)`` with ``p(v|z) = a_z(v) / sum_v' a_z(v')``, over the sampled views.
In bits. A face seen from few views has a large ``I2(z; V)``: a view that
shows much of such faces scores high.

Higher is better, as quoniam (the survey authors' framework) ranks its ``I3``.

A view that sees nothing: NaN (normalised to the worst). Quoniam gives such
a view the smallest I3 of the other views, also the worst; NaN keeps it
out of the other views' range. Faces no view sees carry no weight.

Source: DeWeese and Meister (1999), for viewpoint selection Feixas, Sbert
and González (2009); survey of Bonaventura et al. (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure


def _compute(data: ViewData) -> NDArray[np.float64]:
    _, faces, counts = data.entries
    p_view = data.view_probability[data.seen]
    view_entropy = -float(np.sum(p_view * np.log2(p_view)))
    totals = data.face_totals  # sum_v a_z(v)
    sum_a_log_a = np.bincount(faces, weights=data.entry_xlogx, minlength=data.n_faces)
    seen_faces = totals > 0
    face_information = np.zeros(data.n_faces)  # I2(z; V), 0 where no view sees z
    face_information[seen_faces] = view_entropy - (
        np.log2(totals[seen_faces]) - sum_a_log_a[seen_faces] / totals[seen_faces])
    a_t = data.projected
    seen = data.seen
    weighted = data.per_view(counts * face_information[faces])
    values = np.full(data.n_views, np.nan)
    values[seen] = weighted[seen] / a_t[seen]
    return values


MEASURE = Measure(
    name="I3",
    title="viewpoint specific information (I3)",
    family="information",
    higher_is_better=True,
    needs=frozenset({"pixels"}),
    compute=_compute,
    source="DeWeese and Meister (1999); Feixas, Sbert and González (2009)",
)
