"""I2, viewpoint specific information (the surprise of a view).

``I2(v; Z) = H(Z) - H(Z|v)`` with ``H(Z) = -sum_z p(z) log2 p(z)``,
``p(z) = sum_v a_z(v) / sum_v a_t(v)`` over the sampled views (as VMI takes
it), and ``H(Z|v) = -sum_z p(z|v) log2 p(z|v)``, ``p(z|v) = a_z(v) / a_t(v)``
(the viewpoint entropy VE). In bits. ``H(Z)`` is the same for every view, so
I2 orders the views as VE does, reversed.

Lower is better: the view whose face distribution is least surprising given
what all views see, as quoniam (the survey authors' framework) ranks its
``I2``.

A view that sees nothing: NaN (normalised to the worst). Quoniam gives such
a view the largest I2 of the other views, also the worst; NaN keeps it
out of the other views' range.

Source: DeWeese and Meister (1999), for viewpoint selection Feixas, Sbert
and González (2009); survey of Bonaventura et al. (2018).
"""

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure
from vptoolkit.measures.sums import nonnegative_bits


def _compute(data: ViewData) -> NDArray[np.float64]:
    p_face = data.face_probability[data.face_probability > 0]
    face_entropy = 0.0 - float(np.sum(p_face * np.log2(p_face)))  # +0, not -0, for one face
    a_t = data.projected
    seen = data.seen
    sum_a_log_a = data.per_view(data.entry_xlogx)
    values = np.full(data.n_views, np.nan)
    view_entropy = nonnegative_bits(np.log2(a_t[seen]) - sum_a_log_a[seen] / a_t[seen])
    values[seen] = face_entropy - view_entropy
    return values


MEASURE = Measure(
    name="I2",
    title="viewpoint specific information (I2)",
    family="information",
    higher_is_better=False,
    needs=frozenset({"pixels"}),
    compute=_compute,
    source="DeWeese and Meister (1999); Feixas, Sbert and González (2009)",
)
