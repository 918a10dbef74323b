"""Score predicted view *sets* by the surface they show, against the greedy sets.

A predicted set of ``k`` directions per model is snapped to the nearest
sampled views (the authors' protocol); its coverage (area-weighted fraction
of the surface seen, :mod:`vptoolkit.view_sets`) after 1..k views is compared
with the greedy coverage set's. Files hold ``names`` and ``directions``
``(n_models, k, 3)`` (``.npz``) or the directions alone in the split's order
(``.npy``). Drawing a model's views needs the measuring stack
(:mod:`vptoolkit.visibility`), imported on first use.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.conventions import Split
from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.errors import InputError
from vptoolkit.evaluate._inputs import (
    ReportModels,
    check_directions,
    check_models,
    name_rows,
    report_split,
    select_split,
    split_label,
)
from vptoolkit.predictions import read_arrays, unicode_vector

__all__ = [
    "ViewSetReport",
    "score_view_sets",
    "evaluate_view_sets",
    "model_visibility",
    "model_view_set",
    "stored_view_set",
]



@dataclass(frozen=True, eq=False)
class ViewSetReport(ReportModels):
    """Coverage of predicted view sets against the greedy sets, per model.

    Attributes
    ----------
    dataset, split, predictions, names, model_categories
        The evaluated models (:class:`~vptoolkit.evaluate._inputs.ReportModels`).
    predicted : (n_models, k) float64
        Coverage (area-weighted fraction of the surface seen,
        :mod:`vptoolkit.view_sets`) after the first 1..k predicted views.
    greedy : (n_models, k) float64
        The same for the greedy coverage set over the sampled views (a set
        that stopped early keeps its final value).
    """

    predicted: NDArray[np.float64]
    greedy: NDArray[np.float64]

    @property
    def k(self) -> int:
        """Views per set."""
        return int(self.predicted.shape[1])

    @property
    def ratio(self) -> NDArray[np.float64]:
        """``(n_models,) float64``: predicted over greedy coverage of the whole set, in %."""
        return np.asarray(100.0 * self.predicted[:, -1] / self.greedy[:, -1], dtype=np.float64)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe report: per category and overall means, and every model."""
        is_in = {c: np.array([m == c for m in self.model_categories]) for c in self.categories}
        return {
            "dataset": self.dataset, "split": self.split, "predictions": self.predictions,
            "k": self.k, "n_models": len(self.names),
            "protocol": "coverage of the nearest sampled views vs the greedy coverage set",
            "categories": {c: {"n_models": int(is_in[c].sum()),
                               "predicted": float(self.predicted[is_in[c], -1].mean()),
                               "greedy": float(self.greedy[is_in[c], -1].mean()),
                               "ratio_percent": float(self.ratio[is_in[c]].mean())}
                           for c in self.categories},
            "mean": {"predicted": [float(v) for v in self.predicted.mean(axis=0)],
                     "greedy": [float(v) for v in self.greedy.mean(axis=0)],
                     "ratio_percent": float(self.ratio.mean())},
            "models": [{"name": n, "category": c, "predicted": [float(v) for v in p],
                        "greedy": [float(v) for v in g]}
                       for n, c, p, g in zip(self.names, self.model_categories, self.predicted,
                                             self.greedy)],
        }

    def format_table(self) -> str:
        """Per category: mean coverage of the predicted and greedy k-sets and their ratio."""
        lines = [f"{self.predictions} on split {self.split!r} of {self.dataset}, "
                 f"{len(self.names)} models: coverage of {self.k} views in % "
                 "(predicted / greedy set over the sampled views)",
                 f"{'category':<16} {'n':>4} {'predicted':>10} {'greedy':>8} {'ratio':>7}"]
        summary = self.to_dict()
        for category, row in summary["categories"].items():
            lines.append(f"{category:<16} {row['n_models']:>4} {100 * row['predicted']:>10.1f} "
                         f"{100 * row['greedy']:>8.1f} {row['ratio_percent']:>7.1f}")
        predicted, greedy = 100 * self.predicted[:, -1].mean(), 100 * self.greedy[:, -1].mean()
        lines.append(f"{'mean':<16} {len(self.names):>4} {predicted:>10.1f} {greedy:>8.1f} "
                     f"{self.ratio.mean():>7.1f}")
        per_k = "  ".join(f"{i + 1}: {100 * p:.1f}/{100 * g:.1f}" for i, (p, g) in enumerate(
            zip(self.predicted.mean(axis=0), self.greedy.mean(axis=0))))
        lines.append(f"by number of views (predicted/greedy %): {per_k}")
        return "\n".join(lines)


def _load_view_sets(path: str | os.PathLike[str], dataset: ViewpointDataset,
                    where: str) -> NDArray[np.float64]:
    """``(n_models, k, 3)`` directions in the dataset's order from a .npy or .npz."""
    path = Path(path)
    loaded = read_arrays(path)
    expected = dataset.names
    if isinstance(loaded, np.ndarray):
        names, raw = list(expected), loaded
    else:
        missing_keys = [key for key in ("names", "directions") if key not in loaded]
        if missing_keys:
            raise InputError(f"{path.name}: missing key(s) {', '.join(missing_keys)} "
                             f"(has {', '.join(sorted(loaded)) or 'none'})")
        names, raw = unicode_vector(path.name, "names", loaded["names"]), loaded["directions"]
    if raw.ndim != 3 or raw.shape[2] != 3 or raw.shape[1] < 1:
        raise InputError(f"{path.name}: expected view sets of shape (n_models, k, 3), "
                         f"got {raw.shape}")
    if isinstance(loaded, np.ndarray) and len(raw) != len(expected):
        raise InputError(f"{path.name}: holds {len(raw)} view sets, {where} has "
                         f"{len(expected)} models")
    if len(names) != raw.shape[0]:
        raise InputError(f"{path.name}: {len(names)} names for {raw.shape[0]} view sets")
    position = name_rows(path.name, names, expected, where)
    if len(set(names)) != len(names) or len(names) != len(expected):
        raise InputError(f"{path.name}: holds {len(names)} view sets, {where} has "
                         f"{len(expected)} models (each exactly once)")
    columns = [f"view {i + 1}" for i in range(raw.shape[1])]
    values = check_directions(path.name, raw, names, columns)
    ordered = np.zeros_like(values)
    ordered[[position[name] for name in names]] = values
    return ordered


def model_visibility(dataset: ViewpointDataset, key: int | str, *,
                     views: ArrayLike | None = None) -> Any:
    """Pixel counts of one model's stored mesh from the sampled views of the dataset.

    Drawn as the build drew them: the dataset's views, resolution and camera
    (root attributes), on the cleaned mesh it stores (float32 vertices, so a
    pixel on a triangle edge may differ from the build's count).

    Parameters
    ----------
    dataset : ViewpointDataset
        The dataset.
    key : int or str
        Item index or model name.
    views : (n,) array_like of int, optional
        Draw only these rows of ``dataset.views``, in this order (default: all).

    Returns
    -------
    FaceVisibility
        See :class:`vptoolkit.view_sets.visibility.FaceVisibility`.
    """
    from vptoolkit.mesh import Mesh
    from vptoolkit.settings import MeasureSettings
    from vptoolkit.view_sets.visibility import FaceVisibility

    attrs = dataset.attrs
    vertices, faces = dataset.mesh(key)
    name = dataset.record(key)["name"]
    mesh = Mesh(vertices.astype(np.float64), faces.astype(np.int64), name)
    chosen = dataset.views if views is None else dataset.views[np.asarray(views, dtype=np.int64)]
    settings = MeasureSettings(views=len(chosen), resolution=int(attrs["resolution"]),
                               camera=dataset.camera)
    return FaceVisibility.from_mesh(mesh, settings, view_directions=chosen)


def stored_view_set(dataset: ViewpointDataset, key: int | str, k: int) -> Any:
    """The build's greedy coverage set cut to ``k`` views, if the store answers ``k``.

    Returns
    -------
    ViewSet or None
        None when the store has no view sets, or its set is shorter than
        ``k`` without having stopped for lack of anything new to see.
    """
    stored = dataset.view_set(key)
    if stored is None or (len(stored) < k and stored.coverage[-1] < stored.reachable - 1e-6):
        return None
    return dataset.view_set(key, k)


def model_view_set(dataset: ViewpointDataset, key: int | str, k: int) -> Any:
    """A model's greedy coverage set of ``k`` views: the stored one, else searched here.

    Returns
    -------
    ViewSet
        :func:`stored_view_set`, or :func:`vptoolkit.view_sets.search.best_view_set`
        over :func:`model_visibility`.
    """
    from vptoolkit.view_sets.search import best_view_set

    stored = stored_view_set(dataset, key, k)
    return stored if stored is not None else best_view_set(model_visibility(dataset, key), k)


def score_view_sets(
    dataset: ViewpointDataset,
    directions: ArrayLike,
    *,
    split: str | None = None,
    predictions: str = "<array>",
) -> ViewSetReport:
    """Coverage of predicted view sets, against the greedy coverage sets.

    Each predicted direction is snapped to its nearest sampled view (the
    authors' protocol), the model's stored mesh is drawn from every sampled
    view at the dataset's resolution and camera, and
    :func:`vptoolkit.view_sets.search.set_coverage` gives the coverage of the
    predicted set after 1..k views; :func:`vptoolkit.view_sets.search.best_view_set`
    gives the greedy set's (within ``1 - 1/e`` of the best k-set, so a ratio
    above 100 % is possible but rare).

    Parameters
    ----------
    dataset : ViewpointDataset
        The evaluated models.
    directions : (n_models, k, 3) array_like
        Row ``i`` holds ``k`` directions for ``dataset[i]``, in the order they
        are meant to be shown.
    split, predictions : str, optional
        Labels of the report.

    Returns
    -------
    ViewSetReport
        Where the dataset stores a model's greedy set (``build-dataset``
        does, up to 6 views), only the predicted views are drawn.

    Raises
    ------
    InputError
        On an empty dataset or a wrong shape.
    """
    from vptoolkit.sphere import nearest_view
    from vptoolkit.view_sets.search import best_view_set, set_coverage

    n_models = check_models(dataset)
    values = np.asarray(directions, dtype=np.float64)
    if values.ndim != 3 or values.shape[0] != n_models or values.shape[2] != 3:
        raise InputError(f"directions: expected shape ({n_models}, k, 3), got {values.shape}")
    k = values.shape[1]
    predicted = np.zeros((n_models, k))
    greedy = np.zeros((n_models, k))
    for model in range(n_models):
        nearest = nearest_view(values[model], dataset.views)
        stored = stored_view_set(dataset, model, k)
        if stored is not None:
            # the build's greedy set: only the predicted views need drawing
            visibility = model_visibility(dataset, model, views=nearest)
            predicted[model] = set_coverage(visibility, np.arange(k))
            best = stored.coverage[:k]
        else:
            visibility = model_visibility(dataset, model)
            predicted[model] = set_coverage(visibility, nearest)
            best = best_view_set(visibility, k).coverage
        greedy[model] = np.concatenate([best, np.full(k - len(best), best[-1])])
    split = report_split(dataset, split)
    return ViewSetReport(dataset.path.name, split, predictions, tuple(dataset.names),
                         tuple(dataset.categories), predicted, greedy)


def evaluate_view_sets(
    dataset: ViewpointDataset | str | os.PathLike[str],
    predictions_path: str | os.PathLike[str],
    *,
    split: Split = "test",
) -> ViewSetReport:
    """Score a file of predicted view sets on one split (see :func:`score_view_sets`).

    Parameters
    ----------
    dataset : ViewpointDataset or path-like
        An open dataset, or a store path.
    predictions_path : path-like
        ``*.npz`` with ``names`` (n_models,) and ``directions`` (n_models, k, 3),
        or a ``*.npy`` of shape (n_models, k, 3) in the split's order.
    split : str or None
        ``"train"``, ``"validation"`` (alias ``"val"``), ``"test"`` (default)
        or None for every model (reported as ``"all"``).

    Returns
    -------
    ViewSetReport
    """
    if not isinstance(dataset, ViewpointDataset):
        with open_dataset(dataset) as opened:
            return evaluate_view_sets(opened, predictions_path, split=split)
    selected = select_split(dataset, split)
    label = split_label(split)
    directions = _load_view_sets(predictions_path, selected,
                                 f"split {label!r} of {dataset.path.name}")
    return score_view_sets(selected, directions, split=label,
                           predictions=Path(predictions_path).name)
