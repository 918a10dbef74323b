"""Viewpoint quality measures: a registry of the field's measures and their computation.

Modules, one concept each:

- ``measure``: :class:`~vptoolkit.measures.measure.Measure`, what a measure
  is, its families and needs.
- ``registry``: the one vocabulary of measures, the catalog's measures by
  name, the presets (``"paper"``, ``"all"``), names in any case from what a
  user wrote (``"ve,SL"``).
- ``data``: :class:`~vptoolkit.measures.data.ViewData`, the drawn views of one
  mesh and what the measures derive from them.
- ``sums``: the paper's four from per-view sums of the streamed pixel counts
  (:func:`~vptoolkit.measures.sums.quality_from_histograms`).
- ``session``: :class:`~vptoolkit.measures.session.MeasuringSession`, a mesh
  prepared once and a list of measures, asked for any views; each needed
  pass runs once, streaming where the measures allow.
- ``quality``: :func:`~vptoolkit.measures.quality.compute_view_quality` and
  ``ViewQuality``, any registered measures of a mesh's views (the paper's four,
  by default, streamed from the pixel counts), normalisation and ranking.
- ``curvature``: the per-face mean curvature of a mesh, computed once per mesh.
- ``unoccluded``: VE, VR, VKL and VMI with occlusion ignored, in closed form
  from normals and areas, and the zero-view best directions they give.
- ``saliency``: per-face saliency (Feixas et al.'s from the views, Lee et al.'s
  from the curvature), computed once per mesh.
- ``_kernels``: the compiled sums (numba, imported lazily by the functions
  that use them) of the pairwise divergences of the saliency and of INS,
  of Lee et al.'s Gaussian weights and of the per-view sums.
- ``catalog``: one module per measure, listed in order (``CATALOG``).

Import each name from its module (``from vptoolkit.measures.quality import
compute_view_quality``); this package imports nothing.
"""
