"""The best view per measure within a budget of drawn views.

``search``
    The anytime search of one mesh (:func:`~vptoolkit.best_view.search.search_best_views`):
    coarse sphere, prior, confirmation and pattern-search refinement, with
    its settings as one checked value (``SearchSettings``).
``answer``
    What a search returns (``BestViews``: directions, raw values, stages and
    camera poses per measure; ``SearchStage``).
``prior``
    Who proposes the first candidates: the ``Prior`` protocol,
    ``UnoccludedPrior`` and :func:`~vptoolkit.best_view.prior.resolve_prior`,
    a prior by name.
``run``
    The search over mesh files and a dataset split, as ``vptool best-view``
    runs it (:func:`~vptoolkit.best_view.run.search_inputs`, ``SearchRun``).

The principal-frame coarse sphere the search starts from is
:func:`vptoolkit.sphere.coarse_directions`. Import each name from its module
(``from vptoolkit.best_view.search import search_best_views``); this package
imports nothing.
"""
