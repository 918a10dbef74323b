"""Score one predicted direction per model and measure against the sampled views.

The authors' protocol (Schelling et al. 2021, section 5.2): a predicted
direction scores the *normalised* quality (1 = best view of that model) of the
sampled view nearest to it in angle, reported in percent. A model's score is
taken per measure; a category's score is the mean over its models; the
headline ``mean`` is the unweighted mean over categories, as in the paper's
table 2 (its ML+GL ``mean`` row equals the mean of its eight category rows).

Measures
    A dataset records its measures (:attr:`ViewpointDataset.measures
    <vptoolkit.data.ViewpointDataset.measures>`, the store's ``measures``
    attribute: the paper's four, ``("VE", "VR", "VKL", "VMI")``, unless it
    was built with others), and its quality arrays have one column per
    name, ``M`` in all. Every score array, table, JSON report and category
    summary here lists the dataset's measures in its order; a prediction
    names any of them, and a measure it does not name shows as not
    predicted (NaN, ``-`` in tables).

Predictions come as a file (:func:`load_predictions`):

``*.npz``
    ``names`` : (n_models,) unicode, model names (any order, matched by name);
    ``directions`` : (n_models, n_measures, 3) float, one direction per measure;
    ``measures`` : (n_measures,) unicode, names the dataset records, in any
    order (the paper's four in theirs, see :mod:`vptoolkit.predictions`),
    e.g. ``["VKL"]`` or ``["SL", "NVT"]``. Other keys are ignored.
    :func:`vptoolkit.predictions.write_predictions` writes this form (the
    format's owner, :mod:`vptoolkit.predictions`).
``*.npy``
    (n_models, M, 3) in the dataset's measure order, or (n_models, 3) for the
    one measure named by ``measure``; rows in the order of the evaluated
    split.

Directions point from the model centre towards the camera and need not be
unit length. Files are read with ``allow_pickle=False``.

Baselines to compare with live in :mod:`vptoolkit.evaluate.baselines`; view
sets are scored by coverage in :mod:`vptoolkit.evaluate.coverage`.

This module needs numpy alone (plus the store's zarr or h5py through
:mod:`vptoolkit.data`); it never imports torch, open3d or pymeshlab.
"""

from __future__ import annotations

import math
import os
from collections import Counter
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
    counted,
    name_rows,
    quoted,
    report_split,
    select_split,
    split_label,
)
from vptoolkit.measures.registry import PAPER_MEASURES, all_measures
from vptoolkit.predictions import parse_predictions, read_arrays

__all__ = [
    "EvaluationReport",
    "load_predictions",
    "recorded_measure",
    "score_directions",
    "evaluate_predictions",
]


# --------------------------------------------------------------------------- report


def _percent_or_none(value: float) -> float | None:
    return None if math.isnan(value) else float(value)


@dataclass(frozen=True, eq=False)
class EvaluationReport(ReportModels):
    """Scores of one set of predictions on one split, in percent.

    The derived tables are properties: :attr:`categories`,
    :attr:`category_counts`, :attr:`category_scores`, :attr:`mean` (over
    categories, the paper's headline) and :attr:`model_mean` (over models).

    Attributes
    ----------
    dataset, split, predictions, names, model_categories
        The evaluated models (:class:`~vptoolkit.evaluate._inputs.ReportModels`).
    scores : (n_models, M) float64
        Normalised quality of the nearest sampled view, in percent, one
        column per name of ``measures``; NaN for a measure that was not
        predicted. Read-only.
    measures : tuple of str
        The dataset's measures, the column order of every score array
        (default: the paper's four, ``PAPER_MEASURES``).
    """

    scores: NDArray[np.float64]
    measures: tuple[str, ...] = PAPER_MEASURES

    def __post_init__(self) -> None:
        scores = np.array(self.scores, dtype=np.float64)
        measures = tuple(str(name) for name in self.measures)
        n_models = len(self.names)
        if n_models == 0:
            raise InputError("scores: a report needs at least one model")
        if not measures or len(set(measures)) != len(measures):
            raise InputError(f"measures: expected distinct names, got {list(measures)}")
        if scores.shape != (n_models, len(measures)) or len(self.model_categories) != n_models:
            raise InputError(
                f"scores: expected shape ({n_models}, {len(measures)}) and {n_models} categories, "
                f"got {scores.shape} and {len(self.model_categories)}"
            )
        scores.flags.writeable = False
        object.__setattr__(self, "scores", scores)
        object.__setattr__(self, "measures", measures)
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "model_categories", tuple(self.model_categories))

    @property
    def n_models(self) -> int:
        """Number of evaluated models."""
        return len(self.names)

    @property
    def is_scored(self) -> NDArray[np.bool_]:
        """``(M,) bool``: was each measure predicted?"""
        return np.asarray(~np.isnan(self.scores).all(axis=0))

    @property
    def scored_measures(self) -> tuple[str, ...]:
        """Names of the predicted measures, in :attr:`measures` order."""
        return tuple(m for m, is_scored in zip(self.measures, self.is_scored) if is_scored)

    @property
    def category_counts(self) -> NDArray[np.int64]:
        """``(n_categories,) int64``: models per category, in :attr:`categories` order."""
        categories = np.array(self.model_categories)
        return np.array([int((categories == c).sum()) for c in self.categories], np.int64)

    @property
    def category_scores(self) -> NDArray[np.float64]:
        """``(n_categories, M) float64``: mean score of each category's models, in %."""
        categories = np.array(self.model_categories)
        return np.stack([self.scores[categories == c].mean(axis=0) for c in self.categories])

    @property
    def mean(self) -> NDArray[np.float64]:
        """``(M,) float64``: unweighted mean over categories, in % (the paper's ``mean``)."""
        return np.asarray(self.category_scores.mean(axis=0), dtype=np.float64)

    @property
    def model_mean(self) -> NDArray[np.float64]:
        """``(M,) float64``: mean over all models regardless of category, in %."""
        return np.asarray(self.scores.mean(axis=0), dtype=np.float64)

    def to_dict(self, *, per_model: bool = False) -> dict[str, Any]:
        """The report as JSON-safe types (NaN becomes ``None``).

        Parameters
        ----------
        per_model : bool
            Also list every model's scores under ``"models"`` (default: False).

        Returns
        -------
        report : dict
            ``dataset``, ``split``, ``predictions``, ``n_models``,
            ``measures`` (the dataset's, in its order), ``scored_measures``,
            ``unit`` (``"percent"``), ``protocol``, ``categories``
            (``{category: {"n_models": int, "VE": float | None, ...}}``),
            ``mean`` (over categories) and ``model_mean`` (over models), each
            ``{"VE": float | None, ...}`` by measure name; with ``per_model``,
            ``models``: a list of ``{"name", "category", "VE", ...}``.
        """

        def by_measure(row: NDArray[np.float64]) -> dict[str, float | None]:
            return {m: _percent_or_none(float(v)) for m, v in zip(self.measures, row)}

        categories = {
            category: {"n_models": int(count), **by_measure(row)}
            for category, count, row in zip(self.categories, self.category_counts,
                                            self.category_scores)
        }
        report: dict[str, Any] = {
            "dataset": self.dataset,
            "split": self.split,
            "predictions": self.predictions,
            "n_models": self.n_models,
            "measures": list(self.measures),
            "scored_measures": list(self.scored_measures),
            "unit": "percent",
            "protocol": "normalised quality of the nearest sampled view",
            "categories": categories,
            "mean": by_measure(self.mean),
            "model_mean": by_measure(self.model_mean),
        }
        if per_model:
            report["models"] = [
                {"name": name, "category": category, **by_measure(row)}
                for name, category, row in zip(self.names, self.model_categories, self.scores)
            ]
        return report

    def format_table(self, *, transpose: bool = False, digits: int = 1) -> str:
        """The scores as a plain-text table, one caption line first.

        Parameters
        ----------
        transpose : bool
            False (default): the layout of the paper's table 2, one row per
            category plus a ``mean`` row, one column per measure, with the
            number of models in column ``n``. True: the layout of the paper's
            appendix table, one row per measure, one column per category plus
            ``mean``.
        digits : int
            Decimals of the percentages (default: 1, as in the paper).

        Returns
        -------
        table : str
            Lines joined by ``"\\n"``, no trailing newline. A measure that was
            not predicted shows ``-``.
        """
        if isinstance(digits, bool) or not isinstance(digits, (int, np.integer)) or digits < 0:
            raise InputError(f"digits: expected a non-negative integer, got {digits!r}")

        def cell(value: float) -> str:
            return "-" if math.isnan(value) else f"{value:.{digits}f}"

        caption = (
            f"{self.predictions} on split {self.split!r} of {self.dataset}, {self.n_models} "
            "models: normalised quality of the nearest sampled view in % "
            "(mean = unweighted mean over categories)"
        )
        if transpose:
            header = ["measure", *self.categories, "mean"]
            body = [[m, *(cell(v) for v in column), cell(mean)]
                    for m, column, mean in zip(self.measures, self.category_scores.T,
                                               self.mean)]
            counts = ["n", *(str(int(c)) for c in self.category_counts), str(self.n_models)]
            rows = [header, counts, None, *body]
        else:
            header = ["category", "n", *self.measures]
            body = [[category, str(int(count)), *(cell(v) for v in row)]
                    for category, count, row in zip(self.categories, self.category_counts,
                                                    self.category_scores)]
            mean_row = ["mean", str(self.n_models), *(cell(v) for v in self.mean)]
            rows = [header, None, *body, None, mean_row]
        cells = [row for row in rows if row is not None]
        widths = [max(len(row[column]) for row in cells) for column in range(len(header))]
        widths[1:] = [max(width, 5) for width in widths[1:]]  # room for "100.0" when blank
        rule = "  ".join("-" * width for width in widths)
        lines = [caption]
        for row in rows:
            if row is None:
                lines.append(rule)
                continue
            first = row[0].ljust(widths[0])
            rest = (text.rjust(width) for text, width in zip(row[1:], widths[1:]))
            lines.append("  ".join([first, *rest]))
        return "\n".join(lines)


# --------------------------------------------------------------------------- loading


def recorded_measure(dataset: ViewpointDataset, measure: str | None) -> int | None:
    """Column of ``measure`` among the dataset's recorded measures, or None for None.

    The name is matched case-insensitively (``"vkl"`` is VKL).

    Raises
    ------
    InputError
        One line naming the argument: a name the registry does not know, or
        one the dataset does not record (both list what it records).
    """
    if measure is None:
        return None
    recorded = dataset.measures
    folded = {name.upper(): column for column, name in enumerate(recorded)}
    text = str(measure)
    if text.upper() in folded:
        return folded[text.upper()]
    known = {name.upper() for name in all_measures()}
    problem = "unknown measure" if text.upper() not in known else "measure not recorded,"
    raise InputError(f"measure: {problem} {text!r}; {dataset.path.name} records "
                     f"{', '.join(recorded)}")


def _load(path: str | os.PathLike[str], dataset: ViewpointDataset, measure: str | None,
          where: str) -> tuple[list[str], NDArray[np.float64]]:
    path = Path(path)
    file_name = path.name
    column = recorded_measure(dataset, measure)
    recorded = dataset.measures
    expected_names = dataset.names
    n_models = len(expected_names)
    directions = np.full((n_models, len(recorded), 3), np.nan)
    loaded = read_arrays(path)

    if isinstance(loaded, np.ndarray):
        if loaded.ndim == 2 and loaded.shape[1] == 3:
            if column is None:
                raise InputError(f"{file_name}: an (n_models, 3) array needs the measure it "
                                 "predicts (--measure)")
            columns = [column]
            loaded = loaded[:, None, :]
        elif loaded.ndim == 3 and loaded.shape[1:] == (len(recorded), 3):
            columns = list(range(len(recorded)))
        else:
            raise InputError(f"{file_name}: expected shape (n_models, {len(recorded)}, 3) "
                             f"(measures {', '.join(recorded)}) or (n_models, 3), "
                             f"got {loaded.shape}")
        if loaded.shape[0] != n_models:
            raise InputError(f"{file_name}: holds {loaded.shape[0]} predictions, "
                             f"{where} has {n_models} models")
        values = check_directions(file_name, loaded, expected_names,
                                  [recorded[c] for c in columns])
        rows = np.arange(n_models)
    else:
        names_tuple, raw, measures_tuple = parse_predictions(file_name, loaded)
        names, file_measures = list(names_tuple), list(measures_tuple)
        unrecorded = [m for m in file_measures if m not in recorded]
        if unrecorded:
            raise InputError(f"{file_name}: {counted(len(unrecorded), 'measure', 'measures')} "
                             f"not recorded in {dataset.path.name}: {quoted(unrecorded)} "
                             f"(it records {', '.join(recorded)})")
        columns = [recorded.index(m) for m in file_measures]
        values = check_directions(file_name, raw, names, file_measures)
        duplicates = sorted(name for name, count in Counter(names).items() if count > 1)
        if duplicates:
            raise InputError(f"{file_name}: duplicate names {quoted(duplicates)}")
        position = name_rows(file_name, names, expected_names, where)
        if len(names) != n_models:
            have = set(names)
            missing = [name for name in expected_names if name not in have]
            raise InputError(f"{file_name}: holds {len(names)} predictions, {where} has "
                             f"{n_models} models; missing {quoted(missing)}")
        rows = np.array([position[name] for name in names], dtype=np.int64)

    if column is not None:
        if column not in columns:
            raise InputError(f"{file_name}: measure {recorded[column]!r} is not predicted "
                             f"(file has {', '.join(recorded[c] for c in columns)})")
        values = values[:, [columns.index(column)], :]
        columns = [column]
    directions[rows[:, None], np.array(columns)[None, :], :] = values
    return list(expected_names), directions


def load_predictions(
    path: str | os.PathLike[str],
    dataset_split: ViewpointDataset,
    *,
    measure: str | None = None,
) -> tuple[list[str], NDArray[np.float64]]:
    """Read a predictions file and align it with the models of a split.

    Parameters
    ----------
    path : path-like
        ``*.npz`` with ``names``, ``directions`` and ``measures``, or ``*.npy``
        of shape (n_models, M, 3) or (n_models, 3); see the module docstring.
    dataset_split : ViewpointDataset
        The models being evaluated, e.g. ``dataset.split("test")``. An
        ``.npz`` must name each of them exactly once; an ``.npy`` must have
        one row per model, in this order.
    measure : str, optional
        Score only this measure, one the dataset records (case-insensitive).
        Required for an (n_models, 3) array.

    Returns
    -------
    names : list of str
        ``dataset_split.names``.
    directions : (n_models, M, 3) float64
        Row ``i`` predicts ``names[i]``, one column per measure the dataset
        records, in its order, as stored (not normalised); all-NaN rows for
        measures not predicted.

    Raises
    ------
    InputError
        One line naming the file: not ``.npy``/``.npz``, missing, unreadable
        with ``allow_pickle=False`` (e.g. an object array), a missing key,
        wrong shape or dtype, NaN, infinite or zero vectors, duplicate or
        unknown names, a count that differs from the split, measures that are
        unknown, repeated or not recorded in the dataset, or a ``measure``
        not predicted. Also for a ``measure`` that is unknown or not recorded
        (naming the argument).
    """
    return _load(path, dataset_split, measure, f"the evaluated models of {dataset_split.path.name}")


# --------------------------------------------------------------------------- scoring


def score_directions(
    dataset: ViewpointDataset,
    directions: ArrayLike,
    *,
    split: str | None = None,
    predictions: str = "<array>",
) -> EvaluationReport:
    """Score directions given in the dataset's model order.

    A direction scores ``100 * quality[nearest view, measure]``, the
    normalised quality (1 = the model's best sampled view) of the sampled view
    nearest to it in angle (:meth:`ViewpointDataset.quality_of`).

    Parameters
    ----------
    dataset : ViewpointDataset
        The evaluated models (a whole dataset or one split).
    directions : (n_models, M, 3) array_like
        Row ``i`` for ``dataset[i]``, one column per measure the dataset
        records (:attr:`ViewpointDataset.measures
        <vptoolkit.data.ViewpointDataset.measures>`), in its order, any
        non-zero length. A measure whose directions are NaN for every model
        is not scored (NaN in the report).
    split : str, optional
        Split label of the report (default: the models' split if they all
        share one, else ``"all"``).
    predictions : str
        Name of the predictions in the report (default: ``"<array>"``).

    Returns
    -------
    EvaluationReport

    Raises
    ------
    InputError
        If the dataset is empty, the shape is wrong, no measure is predicted,
        a measure is predicted for some models only, or a direction is
        infinite or zero.
    """
    n_models = check_models(dataset)
    measures = dataset.measures
    values = np.asarray(directions, dtype=np.float64)
    if values.shape != (n_models, len(measures), 3):
        raise InputError(f"directions: expected shape ({n_models}, {len(measures)}, 3), "
                         f"got {values.shape}")
    is_missing = np.any(np.isnan(values), axis=2)  # (n_models, M)
    is_scored = ~is_missing.all(axis=0)
    partial = [m for m, column in zip(measures, is_missing.T) if 0 < column.sum() < n_models]
    if partial:
        raise InputError(f"directions: measure(s) {', '.join(partial)} predicted for some "
                         "models only; predict every model or none")
    if not is_scored.any():
        raise InputError("directions: no measure is predicted (all NaN)")
    columns = np.flatnonzero(is_scored)
    # Only the direction counts: bring each vector to a largest component of 1 so
    # that its length cannot overflow (directions scaled by 1e308 were scored wrongly).
    scale = np.abs(values).max(axis=2, keepdims=True)
    is_scalable = np.isfinite(scale) & (scale > 0)
    values = np.where(is_scalable, values / np.where(is_scalable, scale, 1.0), values)
    scores = np.full((n_models, len(measures)), np.nan)
    for model in range(n_models):
        quality = dataset.quality_of(model, values[model, columns])  # (n_scored, M)
        scores[model, columns] = 100.0 * quality[np.arange(len(columns)), columns]
    split = report_split(dataset, split)
    return EvaluationReport(
        dataset=dataset.path.name,
        split=split,
        predictions=predictions,
        names=tuple(dataset.names),
        model_categories=tuple(dataset.categories),
        scores=scores,
        measures=measures,
    )


def evaluate_predictions(
    dataset: ViewpointDataset | str | os.PathLike[str],
    predictions_path: str | os.PathLike[str],
    *,
    split: Split = "test",
    measure: str | None = None,
) -> EvaluationReport:
    """Score a predictions file on one split of a dataset.

    Parameters
    ----------
    dataset : ViewpointDataset or path-like
        An open dataset, or a store path to open (and close again).
    predictions_path : path-like
        ``*.npz`` or ``*.npy``; see :func:`load_predictions`.
    split : str or None
        ``"train"``, ``"validation"`` (alias ``"val"``), ``"test"`` (default)
        or None for every model (reported as ``"all"``).
    measure : str, optional
        Score only this measure, one the dataset records; required for an
        (n_models, 3) ``.npy``.

    Returns
    -------
    EvaluationReport
        Per model, per category and mean over categories, in percent.

    Raises
    ------
    InputError
        For an unknown split, a measure that is unknown or not recorded in
        the dataset, an empty split, or any problem of the predictions file
        (one line naming the file).

    Examples
    --------
    >>> report = evaluate_predictions("build/", "predictions.npz")   # doctest: +SKIP
    >>> print(report.format_table())                                 # doctest: +SKIP
    """
    if not isinstance(dataset, ViewpointDataset):
        with open_dataset(dataset) as opened:
            return evaluate_predictions(opened, predictions_path, split=split, measure=measure)
    recorded_measure(dataset, measure)
    selected = select_split(dataset, split)
    label = split_label(split)
    _, directions = _load(predictions_path, selected, measure,
                          f"split {label!r} of {dataset.path.name}")
    return score_directions(selected, directions, split=label,
                            predictions=Path(predictions_path).name)
