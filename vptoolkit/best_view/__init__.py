"""The best view per measure within a budget of drawn views.

``search``
    The anytime search of one mesh (:func:`~vptoolkit.best_view.search.search_best_views`):
    coarse sphere, prior, confirmation and pattern-search refinement, with
    its settings as one checked value (``SearchSettings``) and its answer
    (``BestViews``).
``run``
    The search over mesh files and a dataset split, as ``vptool best-view``
    runs it (:func:`~vptoolkit.best_view.run.search_inputs`, ``SearchRun``).

The principal-frame coarse sphere the search starts from is
:func:`vptoolkit.sphere.coarse_directions`. The names of both modules stay
importable from here (``from vptoolkit.best_view import search_best_views``),
as they were when the package was one module; inside vptoolkit each name is
imported from its own module.
"""

from vptoolkit.best_view.run import SearchRun as SearchRun
from vptoolkit.best_view.run import search_inputs as search_inputs
from vptoolkit.best_view.search import BUDGET as BUDGET
from vptoolkit.best_view.search import COARSE_RESOLUTION as COARSE_RESOLUTION
from vptoolkit.best_view.search import FLAT_BELOW as FLAT_BELOW
from vptoolkit.best_view.search import MAX_BUDGET as MAX_BUDGET
from vptoolkit.best_view.search import MIN_STEP_DEG as MIN_STEP_DEG
from vptoolkit.best_view.search import SEARCH_RESOLUTION as SEARCH_RESOLUTION
from vptoolkit.best_view.search import BestViews as BestViews
from vptoolkit.best_view.search import SearchSettings as SearchSettings
from vptoolkit.best_view.search import SearchStage as SearchStage
from vptoolkit.best_view.search import ring as ring
from vptoolkit.best_view.search import search_best_views as search_best_views
from vptoolkit.geometry import principal_frame as principal_frame
from vptoolkit.sphere import coarse_directions as coarse_directions
