"""INS, viewpoint instability.

``INS(v) = (1 / |N(v)|) sum_{v' in N(v)} JS(v, v')``, the mean Jensen-Shannon
divergence between the face distribution of a view and those of its
neighbouring views ``N(v)``, in bits, in [0, 1]. With ``p(z|v) = a_z(v) /
a_t(v)`` and the weights ``pi = a_t(v) / (a_t(v) + a_t(v'))``,
``pi' = 1 - pi`` (the views' probabilities ``p(v)`` renormalised over the
pair)::

    JS(v, v') = H(pi p(Z|v) + pi' p(Z|v')) - pi H(Z|v) - pi' H(Z|v')

which, with ``T = a_t(v) + a_t(v')`` and ``f(x) = x log2 x``, is
``(f(T) - f(a_t(v)) - f(a_t(v')) - sum_z [f(a_z(v) + a_z(v')) - f(a_z(v))
- f(a_z(v'))]) / T``: only faces both views see enter the sum.

``N(v)`` is the :data:`NEIGHBOURS` nearest views by angle. Quoniam (the
survey authors' framework) takes the views adjacent to ``v`` in the
triangulated sphere of viewpoints, five or six on its subdivided
icosahedron; on a Fibonacci sphere the six nearest views play that part.

Lower is better: a view whose neighbours show nearly the same thing is
stable.

A view that sees nothing, or whose neighbours all see nothing: NaN
(normalised to the worst); a neighbour that sees nothing is left out of the
mean, as in quoniam. Quoniam gives a view that sees nothing the smallest
(best) instability of the other views; NaN instead keeps a view that
shows nothing from being best.

Source: Feixas, Sbert and González (2009); survey of Bonaventura et al. (2018).
"""

from typing import Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._stability import both_seen, neighbour_pairs
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure

NEIGHBOURS: Final = 6
"""Nearest views each view is compared with."""

def _xlogx(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return x * np.log2(x)


def _shared_faces_term(data: ViewData, pairs: NDArray[np.int64]) -> NDArray[np.float64]:
    """``sum_z [f(a_z(v) + a_z(v')) - f(a_z(v)) - f(a_z(v'))]`` per pair, over shared faces.

    :func:`vptoolkit.measures._kernels.view_pair_sums`: one view at a time,
    its counts are spread over a dense per-face row, and the faces of every
    view paired with it that has no more visible faces are looked up in that
    row: a gather per entry, no search.
    """
    from vptoolkit.measures._kernels import view_pair_sums

    _, faces, counts = data.entries
    starts = data.view_starts
    sizes = np.diff(starts)
    walk = np.where(sizes[pairs[:, 0]] <= sizes[pairs[:, 1]], pairs[:, 0], pairs[:, 1])
    other = pairs[:, 0] + pairs[:, 1] - walk
    order = np.argsort(other, kind="stable").astype(np.int64)
    return view_pair_sums(starts, faces, counts, data.entry_xlogx, data.xlogx_table, walk, other,
                          order, data.n_faces)


def _compute(data: ViewData) -> NDArray[np.float64]:
    pairs, slots = neighbour_pairs(data, NEIGHBOURS)
    valid = both_seen(data, pairs)
    a = data.projected[pairs[valid, 0]]
    b = data.projected[pairs[valid, 1]]
    total = a + b
    divergence = np.full(len(pairs), np.nan)
    shared = _shared_faces_term(data, pairs[valid])
    divergence[valid] = np.maximum(
        (_xlogx(total) - _xlogx(a) - _xlogx(b) - shared) / total, 0.0)  # >= 0 up to rounding
    per_slot = divergence[slots]
    usable = np.isfinite(per_slot)
    count = usable.sum(axis=1)
    values = np.full(data.n_views, np.nan)
    defined = data.seen & (count > 0)
    values[defined] = np.where(usable, per_slot, 0.0).sum(axis=1)[defined] / count[defined]
    return values


MEASURE = Measure(
    name="INS",
    title="viewpoint instability",
    family="stability",
    higher_is_better=False,
    needs=frozenset({"pixels", "neighbours"}),
    compute=_compute,
    source="Feixas, Sbert and González (2009)",
)
