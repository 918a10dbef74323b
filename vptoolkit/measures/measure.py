"""What a viewpoint quality measure is: :class:`Measure`, its families and its needs.

A measure is a value: a short name, a family of Bonaventura et al.'s survey
(:data:`FAMILIES`), which way is better, what it reads (:data:`NEEDS`) and a
function of the drawn views. The catalog (:mod:`vptoolkit.measures.catalog`)
declares one per module; the registry (:mod:`vptoolkit.measures.registry`)
names them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.sums import PAPER_COLUMNS

if TYPE_CHECKING:
    from vptoolkit.measures.data import ViewData

__all__ = ["FAMILIES", "IMAGE_NEEDS", "NEEDS", "POINT_NEEDS", "Measure"]

FAMILIES: Final = ("area", "information", "silhouette", "depth", "stability", "surface")
"""The survey's families, in the order ``--measures all`` lists them."""

NEEDS: Final = frozenset({"sums", "pixels", "depth", "silhouette", "curvature", "saliency",
                          "neighbours"})
"""What a measure can need: the shared passes it reads.

``sums``
    only the per-view sums of the streamed pixel counts
    (:mod:`vptoolkit.measures.sums`): the paper's four, whose values are the
    columns of :func:`~vptoolkit.measures.sums.quality_from_histograms`; a
    measuring session computes any of them without keeping any view's counts;
``pixels``
    the per-face pixel counts ``a_z(v)`` of every view, kept together
    (:class:`~vptoolkit.measures.data.ViewData`);
``depth``
    per-view depth statistics (histogram, maximum, a small depth image);
``silhouette``
    per-view silhouette statistics (contour length, turning angles);
``curvature``
    a per-face curvature of the mesh, computed once per mesh;
``saliency``
    a per-face saliency of the mesh, computed once per mesh from all views;
``neighbours``
    the neighbouring views of each view on the sphere.
"""


IMAGE_NEEDS: Final = frozenset({"depth", "silhouette"})
"""The needs that the drawing pass serves with per-view image statistics
(``iter_view_histograms(..., features=True)``)."""

POINT_NEEDS: Final = frozenset({"sums", "pixels", "saliency", "neighbours"})
"""The needs a point cloud serves, its points standing for faces.

The splats of :mod:`vptoolkit.visibility.splats` give per-point pixel counts
(``sums``, ``pixels``) and the points' areas; the views' neighbours do not
depend on the model; Feixas et al.'s saliency (``saliency`` without
``curvature``) pairs each point with its nearest points instead of a face
with its edge neighbours (:func:`vptoolkit.measures.saliency.point_neighbours`).
The splats draw no depth or silhouette statistics, and a cloud has no faces
to take a dihedral-angle curvature from, so a measure needing ``depth``,
``silhouette`` or ``curvature`` is not defined on points.
"""


@dataclass(frozen=True)
class Measure:
    """One viewpoint quality measure.

    Attributes
    ----------
    name : str
        Short name, stored in files (``"VE"``).
    title : str
        What it is called in words (``"viewpoint entropy"``).
    family : str
        One of :data:`FAMILIES`.
    higher_is_better : bool
        Whether a higher raw value marks a better view.
    needs : frozenset of str
        What it reads, a subset of :data:`NEEDS`.
    compute : callable
        ``compute(data) -> (n_views,) float64`` raw values from a
        :class:`~vptoolkit.measures.data.ViewData`; NaN where the measure
        is undefined for a view (one that sees nothing).
    source : str
        Where the measure comes from (authors, year).
    """

    name: str
    title: str
    family: str
    higher_is_better: bool
    needs: frozenset[str]
    compute: Callable[[ViewData], NDArray[np.float64]]
    source: str

    def __post_init__(self) -> None:
        if self.family not in FAMILIES:
            raise ValueError(f"{self.name}: unknown family {self.family!r}")
        unknown = set(self.needs) - NEEDS
        if unknown:
            raise ValueError(f"{self.name}: unknown needs {sorted(unknown)}")
        if "sums" in self.needs and (self.needs != {"sums"} or self.name not in PAPER_COLUMNS):
            raise ValueError(f"{self.name}: only {', '.join(PAPER_COLUMNS)} are computed from "
                             "the sums alone")

    @property
    def streams(self) -> bool:
        """Whether it reads only the streamed per-view sums (no view's counts are kept)."""
        return self.needs == {"sums"}

    @property
    def needs_image_statistics(self) -> bool:
        """Whether the views must be drawn with depth and silhouette statistics."""
        return bool(self.needs & IMAGE_NEEDS)

    @property
    def on_points(self) -> bool:
        """Whether it is defined on a point cloud (its needs within :data:`POINT_NEEDS`)."""
        return self.needs <= POINT_NEEDS
