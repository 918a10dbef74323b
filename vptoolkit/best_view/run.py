"""The best-view search over many inputs: mesh files and a dataset split, failures recorded.

:func:`search_inputs` reads its inputs through the one input router
(:func:`vptoolkit.inputs.open_inputs`), runs
:func:`~vptoolkit.best_view.search.search_best_views` on every mesh with one
:class:`~vptoolkit.best_view.search.SearchSettings` and an optional prior,
and returns a :class:`SearchRun`: the answers, the inputs that failed, and
the answers as :class:`~vptoolkit.predictions.Predictions` that ``vptool
evaluate`` scores. This is what ``vptool best-view`` runs.

Every mesh is searched for the same measures: those asked for, else a
dataset's recorded measures that a search can evaluate
(:func:`recorded_searchable`), else the paper's four. The prior is named
or given as :func:`vptoolkit.best_view.prior.resolve_prior` takes it, and
made once for those measures.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from vptoolkit.best_view.answer import BestViews, SearchStage
from vptoolkit.best_view.prior import resolve_prior
from vptoolkit.best_view.search import (
    UNSEARCHABLE_NEEDS,
    SearchSettings,
    check_search_settings,
    search_best_views,
    searchable_measures,
)
from vptoolkit.checks import one_line
from vptoolkit.conventions import Split
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.inputs import ModelSource, claim_name, open_inputs
from vptoolkit.measures.registry import PAPER_MEASURES, all_measures
from vptoolkit.mesh import Mesh
from vptoolkit.point_cloud import MAX_POINTS, PointCloud
from vptoolkit.predictions import Predictions
from vptoolkit.progress import progress_bar
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.visibility import RasterScene
from vptoolkit.visibility.splats import PointScene

if TYPE_CHECKING:
    from vptoolkit.data import ViewpointDataset

__all__ = ["SearchRun", "load_kernels", "recorded_searchable", "search_inputs"]


@dataclass(frozen=True)
class SearchRun:
    """Best views of several meshes, and the meshes that failed.

    Attributes
    ----------
    results : tuple of BestViews
        In input order.
    failures : tuple of (str, str)
        ``(input, one-line reason)`` for every input that could not be searched.
    is_bad_input : bool
        Whether every failure was bad input (an unreadable or malformed mesh,
        an :class:`~vptoolkit.errors.InputError`), none a measurement failure.
    measures : tuple of str
        The searched measures, the same for every mesh (default: the paper's four).
    files : tuple of str or None
        The file each result was read from, in the order of ``results``; None
        for a dataset's model (default: none recorded).
    """

    results: tuple[BestViews, ...]
    failures: tuple[tuple[str, str], ...]
    is_bad_input: bool = True
    measures: tuple[str, ...] = PAPER_MEASURES
    files: tuple[str | None, ...] = ()

    @property
    def predictions(self) -> Predictions:
        """The answers' directions ``(n_meshes, M, 3)`` by name, with the searched measures'
        names, as ``vptool evaluate`` scores them (write them with
        :meth:`~vptoolkit.predictions.Predictions.save_npz`)."""
        return Predictions(tuple(result.name for result in self.results),
                           np.stack([result.directions for result in self.results])
                           if self.results else np.zeros((0, len(self.measures), 3)),
                           self.measures)


def recorded_searchable(recorded: Sequence[str], where: str = "dataset") -> tuple[str, ...]:
    """The measures of ``recorded`` (a dataset's) that a search can evaluate, in its order.

    Names the registry does not know, and measures with a need in
    :data:`~vptoolkit.best_view.search.UNSEARCHABLE_NEEDS`, are left out.

    Raises
    ------
    InputError
        If none is left (the message starts with ``where``).
    """
    known = all_measures()
    kept = tuple(name for name in recorded
                 if name in known and not known[name].needs & UNSEARCHABLE_NEEDS)
    if not kept:
        raise InputError(f"{where}: records no measure a search can evaluate "
                         f"({', '.join(recorded)}); name the measures to search")
    return kept


def search_inputs(
    inputs: Sequence[str | os.PathLike[str]] = (),
    *,
    settings: SearchSettings = SearchSettings(),
    dataset: str | os.PathLike[str] | ViewpointDataset | None = None,
    split: Split = "test",
    prior: str | os.PathLike[str] | Callable[[Mesh | PointCloud], ArrayLike] | None = None,
    measures: str | Sequence[str] | None = None,
    max_points: int = MAX_POINTS,
    progress: bool = False,
) -> SearchRun:
    """:func:`~vptoolkit.best_view.search.search_best_views` over model files and a dataset
    split; failures recorded, not raised.

    Parameters
    ----------
    inputs : sequence of path-like
        Mesh or point cloud files, decided by content (names: the file
        stems); a cloud is searched for the measures defined on points, and
        a measure that is not is its failure.
    settings : SearchSettings, optional
        Budget, resolution, coarse pass and camera of every search (default:
        ``SearchSettings()``).
    dataset : path-like or ViewpointDataset, optional
        A dataset (store, build or release folder, a release's URL, or one
        opened by :func:`vptoolkit.data.open_dataset`) whose stored, cleaned
        meshes of ``split`` are searched (names: the dataset's).
    split : str, optional
        ``"train"``, ``"validation"``, ``"test"`` or None for all (default: "test").
    prior : str, path-like or callable, optional
        ``"none"``, ``"unoccluded"``, ``"default"``, a checkpoint's path, or
        a :class:`~vptoolkit.best_view.prior.Prior`, ``prior(mesh) -> (k, 3)``
        candidate directions, most promising first
        (:func:`vptoolkit.best_view.prior.resolve_prior`, made once for the
        searched measures; default: None, no prior).
    measures : str or sequence of str, optional
        The measures to search
        (:func:`~vptoolkit.best_view.search.searchable_measures`); default:
        with ``dataset``, the measures it records that a search can evaluate
        (:func:`recorded_searchable`), else the paper's four.
    max_points : int
        Most points a point cloud file keeps; a larger one is thinned on
        reading (:func:`vptoolkit.io.load`; default:
        :data:`~vptoolkit.point_cloud.MAX_POINTS`).
    progress : bool
        Show a progress bar over the meshes on stderr (default: False).

    Raises
    ------
    InputError
        On an invalid option, an unknown measure or one a search cannot
        evaluate, a prior that cannot be made (an unknown name, a missing
        checkpoint), an input that is no mesh, point file or dataset
        (:func:`vptoolkit.inputs.open_inputs`), a dataset that cannot be
        opened or a split of it without models. A mesh that cannot be read
        or measured, or a second model of the same name, is recorded in
        ``failures`` instead.
    """
    chosen = check_search_settings(settings)
    names = None if measures is None else searchable_measures(measures)
    entries = [*inputs, *([] if dataset is None else [dataset])]
    with open_inputs(entries, split=split, purpose="search",
                     max_points=max_points) as sources:
        if names is None:
            stored = next((source.dataset for source in sources if source.dataset is not None),
                          None)
            names = (searchable_measures(None) if stored is None
                     else recorded_searchable(stored.measures, stored.path.name))
        return _search_all(sources, chosen, resolve_prior(prior, measures=names), progress,
                           names)


def load_kernels() -> None:
    """Draw a tetrahedron and a small cloud once, so that numba's one-time kernel loads (the
    rasteriser's and the splats') are not any model's time."""
    tetrahedron = Mesh(np.eye(4, 3, k=-1), np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]),
                       name="tetrahedron")
    list(RasterScene(tetrahedron).histograms(np.eye(3)[:1], 8))
    list(PointScene(fibonacci_sphere(16)).histograms(np.eye(3)[:1], 8))


def _search_all(sources: list[ModelSource], settings: SearchSettings,
                prior: Callable[[Mesh | PointCloud], ArrayLike] | None, progress: bool,
                measures: tuple[str, ...]) -> SearchRun:
    if sources:
        load_kernels()
    results: list[BestViews] = []
    files: list[str | None] = []
    failures: list[tuple[str, str]] = []
    is_bad_input = True
    names: set[str] = set()
    with progress_bar(total=len(sources), description="best views", unit="mesh",
                      enabled=progress) as bar:
        for source in sources:
            claimed: str | None = None
            try:
                mesh = source.model()
                claim_name(names, mesh.name)  # a name counts once its mesh is searched
                claimed = mesh.name
                started = time.perf_counter()
                candidates = prior(mesh) if prior is not None else None
                proposing = time.perf_counter() - started  # part of the answer's cost
                found = search_best_views(mesh, settings, prior=candidates, measures=measures)
                results.append(replace(found, seconds=found.seconds + proposing,
                                       stages=_named_prior(found.stages, prior, mesh)))
                files.append(source.origin if source.kind == "file" else None)
            except (InputError, MeasurementError) as error:
                if claimed is not None:
                    names.discard(claimed)
                failures.append((source.label, one_line(error)))
                is_bad_input = is_bad_input and isinstance(error, InputError)
            bar.update(1)
    return SearchRun(tuple(results), tuple(failures), is_bad_input, measures, tuple(files))


def _named_prior(stages: tuple[SearchStage, ...],
                 prior: Callable[[Mesh | PointCloud], ArrayLike] | None,
                 mesh: Mesh | PointCloud) -> tuple[SearchStage, ...]:
    """``stages`` with the prior stage named ``prior (LABEL)`` where the prior names what
    proposed (``prior.label(mesh)``, :class:`~vptoolkit.best_view.prior.Prior`)."""
    label = getattr(prior, "label", None)
    if not callable(label):
        return stages
    named = f"prior ({label(mesh)})"
    return tuple(replace(stage, name=named) if stage.name == "prior" else stage
                 for stage in stages)
