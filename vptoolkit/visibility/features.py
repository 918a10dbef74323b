"""Per-view image statistics drawn in the same pass as the pixel counts.

Besides the per-face pixel counts, the measures of the depth and silhouette
families (:mod:`vptoolkit.measures`) read a few statistics of each view's
image. They are computed from each image while it is in memory and kept
instead of the image, so 1000 views never hold 1000 images.

Conventions
    *Normalised depth* of a pixel is ``(t - near) / (far - near)`` with ``t``
    the distance along the camera's forward axis to the nearest surface
    through the pixel centre, ``near = d - r`` and ``far = d + r``
    (``d`` the camera's distance to the bounding-box centre, ``r`` half the
    bounding-box diagonal): 0 at the nearest point the model can reach, 1 at
    the farthest. Only covered pixels (a face seen) count.

    The *silhouette* is the boundary of the covered pixels: every contour,
    outer and inner (holes), traced as an 8-connected chain of boundary
    pixels, as OpenCV's ``findContours(RETR_LIST, CHAIN_APPROX_NONE)``
    gives it. Its length counts 1 per axis step and ``sqrt(2)`` per
    diagonal step, closing each contour. The turning angle at a chain pixel
    is the signed angle between the step into it and the step out of it, a
    multiple of 45 degrees in (-180, 180]; an isolated pixel contributes one
    angle of 0.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

__all__ = ["DEPTH_BINS", "THUMBNAIL", "TURNING_BINS", "ViewFeatures"]

DEPTH_BINS: Final = 256
"""Bins of the normalised depth histogram over [0, 1]."""

TURNING_BINS: Final = 9
"""Bins of the turning-angle histogram: bin ``(angle + 180) // 45`` for angles in degrees."""

THUMBNAIL: Final = 64
"""Side of the small depth image kept per view."""


@dataclass(frozen=True)
class ViewFeatures:
    """Image statistics of a run of consecutive views.

    Attributes
    ----------
    depth_histogram : (n_views, DEPTH_BINS) int64
        Covered pixels per bin of normalised depth (bin ``floor(depth *
        DEPTH_BINS)``, the last bin closed).
    max_depth : (n_views,) float64
        Largest normalised depth of a covered pixel; NaN where none is.
    silhouette_length : (n_views,) float64
        Length of all silhouette contours, in pixels.
    turning_histogram : (n_views, TURNING_BINS) int64
        Count of the contours' turning angles per 45-degree bin.
    depth_thumbnail : (n_views, THUMBNAIL, THUMBNAIL) uint8
        The depth image reduced to ``THUMBNAIL`` pixels a side: 0 where the
        block of pixels sees nothing, otherwise ``1 + round(254 * (1 -
        depth))`` of the nearest covered pixel of the block (near is bright).
    """

    depth_histogram: NDArray[np.int64]
    max_depth: NDArray[np.float64]
    silhouette_length: NDArray[np.float64]
    turning_histogram: NDArray[np.int64]
    depth_thumbnail: NDArray[np.uint8]

    @property
    def n_views(self) -> int:
        """Number of views."""
        return int(len(self.max_depth))

    @classmethod
    def concatenate(cls, runs: Sequence[ViewFeatures]) -> ViewFeatures:
        """The statistics of consecutive runs, joined in order."""
        return cls(
            depth_histogram=np.concatenate([r.depth_histogram for r in runs]),
            max_depth=np.concatenate([r.max_depth for r in runs]),
            silhouette_length=np.concatenate([r.silhouette_length for r in runs]),
            turning_histogram=np.concatenate([r.turning_histogram for r in runs]),
            depth_thumbnail=np.concatenate([r.depth_thumbnail for r in runs]),
        )
