"""How close our measures are to the ones stored in a store: :func:`check_measures`.

Made for stores imported from the paper authors' tree
(:func:`vptoolkit.dataset.authors.importer.import_authors`), whose measures were
computed by the authors' pipeline: our pipeline measures the stored meshes
again over the stored views, and for each model and measure this reports

- the Spearman rank correlation between the stored and our normalised quality
  over the views (1 = the same order of views; the normalisation is monotone
  in the raw value, so this is the rank correlation of the raw measures, with
  the sign of a lower-is-better measure such as VKL and VMI turned so that 1
  always means agreement), and
- the angle in degrees between the stored best view and ours,

for every measure the store records (an imported store: the paper's four).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import as_path, check_bool, check_int, one_line
from vptoolkit.dataset.authors.importer import AUTHORS_RESOLUTION
from vptoolkit.errors import VptoolkitError
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.progress import progress_bar
from vptoolkit.sphere import angle_between_deg

__all__ = ["MeasureCheck", "ModelCheck", "check_measures", "rank_correlation"]


@dataclass(frozen=True)
class ModelCheck:
    """One model's comparison.

    Attributes
    ----------
    name : str
        The model.
    correlation : tuple of float or None
        Spearman rank correlation per measure, in the order of the store's
        ``measures``; None where one side is constant over the views.
    best_angle_deg : tuple of float
        Angle in degrees between the stored and our best view, per measure.
    """

    name: str
    correlation: tuple[float | None, ...]
    best_angle_deg: tuple[float, ...]


@dataclass(frozen=True)
class MeasureCheck:
    """Outcome of :func:`check_measures`.

    Attributes
    ----------
    models : tuple of ModelCheck
        The models compared, in store order.
    failures : tuple of str
        One line per chosen model that could not be measured.
    resolution : int
        Image side in pixels of our measurement.
    measures : tuple of str
        The measures compared, the store's (default: the paper's four).
    """

    models: tuple[ModelCheck, ...]
    failures: tuple[str, ...]
    resolution: int
    measures: tuple[str, ...] = PAPER_MEASURES

    def summary(self) -> dict[str, dict[str, float | None]]:
        """Per measure: mean rank correlation, median and mean best-view angle.

        Returns
        -------
        dict
            ``{measure: {"mean_correlation", "median_angle_deg", "mean_angle_deg"}}``;
            None where no model gives a value.
        """
        result: dict[str, dict[str, float | None]] = {}
        for column, measure in enumerate(self.measures):
            values = [value for m in self.models
                      if (value := m.correlation[column]) is not None]
            angles = [m.best_angle_deg[column] for m in self.models]
            result[measure] = {
                "mean_correlation": float(np.mean(values)) if values else None,
                "median_angle_deg": float(np.median(angles)) if angles else None,
                "mean_angle_deg": float(np.mean(angles)) if angles else None,
            }
        return result


def _ranks(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Ranks from 0, tied values sharing their mean rank."""
    order = np.argsort(values, kind="stable")
    ranks = np.empty(len(values), dtype=np.float64)
    ranks[order] = np.arange(len(values), dtype=np.float64)
    _, inverse, counts = np.unique(values, return_inverse=True, return_counts=True)
    sums = np.bincount(inverse, weights=ranks)
    return sums[inverse] / counts[inverse]


def rank_correlation(a: Any, b: Any) -> float | None:
    """Spearman rank correlation of two equally long vectors (ties get mean ranks).

    Returns
    -------
    float or None
        In [-1, 1]; None when either vector is constant.

    Examples
    --------
    >>> rank_correlation([1, 2, 3, 4], [10, 20, 30, 25])
    0.8
    """
    ranks_a = _ranks(np.asarray(a, dtype=np.float64))
    ranks_b = _ranks(np.asarray(b, dtype=np.float64))
    ranks_a -= ranks_a.mean()
    ranks_b -= ranks_b.mean()
    norm = float(np.sqrt((ranks_a @ ranks_a) * (ranks_b @ ranks_b)))
    if norm == 0.0:
        return None
    return round(float(ranks_a @ ranks_b) / norm, 12)


def check_measures(dataset: str | os.PathLike[str], n_models: int, *,
                   resolution: int = AUTHORS_RESOLUTION, progress: bool = False) -> MeasureCheck:
    """Measure ``n_models`` models of a store again with our pipeline and compare.

    Parameters
    ----------
    dataset : path-like
        A store or a folder holding one (:func:`~vptoolkit.dataset.store.containers.find_store`).
    n_models : int
        Models to compare, at least 1, spread evenly over the store's rows
        (all of them when the store has fewer).
    resolution : int
        Side of our triangle-ID image in pixels (default: 1024, that of the
        authors' renders).
    progress : bool
        Show a progress bar on stderr (default: False).

    Returns
    -------
    MeasureCheck
        Per model: the rank correlation per measure and the best-view angle.
        A model without a stored mesh (imported with ``meshes=False``) or
        one our pipeline cannot measure is a failure line.

    Raises
    ------
    InputError
        If the store cannot be opened, records a measure the registry does not
        know, or an argument is invalid.
    """
    from vptoolkit.dataset.store.containers import find_store
    from vptoolkit.dataset.store.reader import open_store
    from vptoolkit.dataset.store.schema import registered_measures
    from vptoolkit.measures.quality import compute_view_quality
    from vptoolkit.mesh import Mesh
    from vptoolkit.settings import MeasureSettings

    n_models = check_int(n_models, "n_models", minimum=1)
    settings = MeasureSettings(resolution=resolution)  # the stored views are drawn
    resolution = settings.resolution
    progress = check_bool(progress, "progress")
    checked: list[ModelCheck] = []
    failures: list[str] = []
    with open_store(find_store(as_path(dataset, "dataset"))) as store:
        measures = store.measures
        registered_measures(measures, store.path.name)  # each one our pipeline can compute
        views = np.asarray(store.array("views"), dtype=np.float64)
        total = store.n_models
        rows = sorted({int(round(x)) for x in np.linspace(0, total - 1, min(n_models, total))}
                      ) if total else []
        with progress_bar(total=len(rows), description="check", unit="model",
                          enabled=progress) as bar:
            for row in rows:
                entry = store.entry(row)
                bar.update(1)
                if len(entry.faces) == 0:
                    failures.append(f"{entry.name}: no stored mesh to measure (imported "
                                    "without meshes)")
                    continue
                try:
                    mesh = Mesh(np.asarray(entry.vertices, dtype=np.float64),
                                np.asarray(entry.faces, dtype=np.int64), name=entry.name)
                    ours = compute_view_quality(mesh, settings, measures=measures,
                                                view_directions=views)
                except VptoolkitError as err:
                    failures.append(f"{entry.name}: {one_line(err)}")
                    continue
                stored = np.asarray(entry.quality, dtype=np.float64)
                correlation = tuple(rank_correlation(stored[:, c], ours.normalized[:, c])
                                    for c in range(len(measures)))
                angles = angle_between_deg(views[np.asarray(entry.best_index)],
                                           views[ours.best_index])
                checked.append(ModelCheck(name=entry.name, correlation=correlation,
                                          best_angle_deg=tuple(float(a) for a in angles)))
    return MeasureCheck(models=tuple(checked), failures=tuple(failures), resolution=resolution,
                        measures=measures)
