"""CE, curvature entropy: how varied the curvature of the surface a view shows is.

``CE(v) = -sum_b p_b(v) log2 p_b(v)``, ``p_b(v) = sum_{z in b} a_z(v) / a_t(v)``,

the entropy in bits of the seen surface's curvature, each face ``z``
weighted by its pixels ``a_z(v)`` and put in the bin ``b`` of its
dimensionless mean curvature

``kappa_z = H_z R``,  ``b = clip(floor(255 (kappa_z + 2 pi) / (4 pi)), 0, 255)``,

with ``H_z`` the face's mean curvature from the dihedral angles of its edges
(:func:`vptoolkit.measures.curvature.face_mean_curvature`, inverse model
units, positive where convex) and ``R`` half the bounding-box diagonal (the
``r`` of the normalised depth), so ``kappa`` does not change with the
model's scale: a sphere's faces get about ``sqrt 3``, a cube's ``sqrt(3) pi
/ 4``, a flat region 0. The bins are quoniam's: 256 over [-2 pi, 2 pi],
index ``floor(255 (kappa - min) / range)``; a curvature beyond the range
goes to the end bin (quoniam clamps only below). CE runs from 0 (all seen
faces in one bin) to 8 bits. Higher is better (quoniam's
``CurvatureEntropy``: maximum best). A view that sees nothing: NaN.

quoniam bins a per-vertex angle deficit (``2 pi - sum`` of the corner
angles, a Gaussian curvature that depends on the tessellation), counts each
visible vertex once and divides the counts by the number of all vertices,
so its value also grows with how many vertices are seen. Here faces are
weighted by their pixels and the distribution is normalised per view: a
true entropy of what the view shows.

Source: Page, Koschan, Sukumar, Roui-Abidi and Abidi (2003), as reviewed by
Bonaventura, Feixas, Sbert, Chuang and Wallraven (2018).
"""

from typing import Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.geometry import bounding_frame
from vptoolkit.measures.catalog._histograms import entropies
from vptoolkit.measures.curvature import mesh_curvature
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure

CURVATURE_BINS: Final = 256
"""Bins of the curvature histogram, as quoniam's."""

CURVATURE_RANGE: Final = (-2.0 * np.pi, 2.0 * np.pi)
"""Range of the dimensionless curvature the bins cover, as quoniam's."""


def curvature_bins(data: ViewData) -> NDArray[np.int64]:
    """The curvature bin of every face, ``(n_faces,) int64`` in ``[0, CURVATURE_BINS)``."""
    _, diagonal = bounding_frame(data.mesh)
    kappa = mesh_curvature(data) * (diagonal / 2.0)
    low, high = CURVATURE_RANGE
    index = np.floor((CURVATURE_BINS - 1) * (kappa - low) / (high - low))
    return np.clip(index, 0, CURVATURE_BINS - 1).astype(np.int64)


def _compute(data: ViewData) -> NDArray[np.float64]:
    views, faces, counts = data.entries
    cells = views * CURVATURE_BINS + curvature_bins(data)[faces]
    histogram = np.bincount(cells, weights=counts, minlength=data.n_views * CURVATURE_BINS)
    return entropies(histogram.reshape(data.n_views, CURVATURE_BINS))


MEASURE = Measure(
    name="CE",
    title="curvature entropy",
    family="surface",
    higher_is_better=True,
    needs=frozenset({"pixels", "curvature"}),
    compute=_compute,
    source="Page, Koschan, Sukumar, Roui-Abidi and Abidi (2003)",
)
