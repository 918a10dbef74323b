"""Viewpoint quality measures: a registry of the field's measures and their computation.

Modules, one concept each:

- ``registry``: :class:`~vptoolkit.measures.registry.Measure`, the registry of
  every measure, names from what a user wrote (``"all"``, ``"VE,SL"``).
- ``data``: :class:`~vptoolkit.measures.data.ViewData`, the drawn views of one
  mesh and what the measures derive from them.
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
- ``catalog``: one module per measure, found by the registry.

Import each name from its module (``from vptoolkit.measures.quality import
compute_view_quality``); this package imports nothing.
"""
