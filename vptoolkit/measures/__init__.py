"""Viewpoint quality measures: a registry of the field's measures and their computation.

Modules, one concept each:

- ``registry``: :class:`Measure`, the registry of every measure, names from
  what a user wrote (``"all"``, ``"VE,SL"``).
- ``data``: :class:`ViewData`, the drawn views of one mesh and what the
  measures derive from them.
- ``quality``: :func:`compute_view_quality` and :class:`ViewQuality`, the
  paper's four from streamed pixel counts, normalisation and ranking.
- ``catalog``: one module per measure, found by the registry.
"""

from vptoolkit.measures.quality import (
    ViewQuality,
    compute_view_quality,
    normalize_quality,
    progress_runs,
    quality_from_histograms,
    ranked_views,
)
from vptoolkit.measures.registry import (
    Measure,
    all_measures,
    get_measure,
    resolve_measures,
)

__all__ = [
    "Measure",
    "ViewQuality",
    "all_measures",
    "compute_view_quality",
    "get_measure",
    "normalize_quality",
    "progress_runs",
    "quality_from_histograms",
    "ranked_views",
    "resolve_measures",
]
