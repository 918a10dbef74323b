"""What both kinds of evaluation share: the checks of their inputs (models, splits,
prediction arrays), their messages and the models a report is about.

Private to :mod:`vptoolkit.evaluate`: :mod:`~vptoolkit.evaluate.scores` (one
direction per model and measure) and :mod:`~vptoolkit.evaluate.coverage`
(view sets) read predictions the same way and word their errors alike.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.conventions import SPLITS, Split
from vptoolkit.data import ViewpointDataset
from vptoolkit.dataset.store.schema import published_split
from vptoolkit.errors import InputError
from vptoolkit.sphere import is_zero_length

_MAX_LISTED = 3  # names quoted in an error message before "..."


@dataclass(frozen=True, eq=False)
class ReportModels:
    """The models an evaluation report is about: the first fields of every report.

    Attributes
    ----------
    dataset : str
        File name of the dataset store.
    split : str
        ``"train"``, ``"val"``, ``"test"`` or ``"all"``.
    predictions : str
        File name of the predictions (``"<array>"`` for in-memory ones).
    names : tuple of str
        The evaluated models, in the split's order.
    model_categories : tuple of str
        Category of each model.
    """

    dataset: str
    split: str
    predictions: str
    names: tuple[str, ...]
    model_categories: tuple[str, ...]

    @property
    def categories(self) -> tuple[str, ...]:
        """The categories present, sorted."""
        return tuple(sorted(set(self.model_categories)))


def quoted(names: Sequence[str]) -> str:
    """The first few names, quoted, then ``...`` if there are more."""
    listed = ", ".join(repr(name) for name in names[:_MAX_LISTED])
    return listed + (", ..." if len(names) > _MAX_LISTED else "")


def counted(n: int, singular: str, plural: str) -> str:
    """``n`` and the noun in the right number: ``1 name``, ``2 names``."""
    return f"{n} {singular if n == 1 else plural}"


def name_rows(file_name: str, names: Sequence[str], expected: Sequence[str],
              where: str) -> dict[str, int]:
    """Row of each model name in ``expected`` order, once every one of ``names`` is among them.

    Returns
    -------
    rows : dict of str to int
        ``{expected[i]: i}``.

    Raises
    ------
    InputError
        Naming the first few of ``names`` missing from ``expected``, e.g.
        ``preds.npz: 2 names not in the test split: 'a', 'b'``.
    """
    rows = {name: i for i, name in enumerate(expected)}
    unknown = [name for name in names if name not in rows]
    if unknown:
        raise InputError(f"{file_name}: {counted(len(unknown), 'name', 'names')} not in "
                         f"{where}: {quoted(unknown)}")
    return rows


def check_directions(file_name: str, directions: NDArray[Any], names: Sequence[str],
                      measures: Sequence[str]) -> NDArray[np.float64]:
    """Cast to float64 and reject non-finite or zero vectors, naming the model."""
    if directions.dtype.kind not in "fiu":
        raise InputError(f"{file_name}: directions must be numeric, got dtype {directions.dtype}")
    values = directions.astype(np.float64)
    is_bad = ~np.isfinite(values).all(axis=-1)
    problem = "NaN or infinite"
    if not is_bad.any():
        is_bad = is_zero_length(values)
        problem = "a zero vector"
    if is_bad.any():
        model, column = np.argwhere(is_bad)[0]
        raise InputError(
            f"{file_name}: direction of {names[model]!r} for {measures[column]} is {problem} "
            f"({int(is_bad.sum())} of {is_bad.size} directions)"
        )
    return values


def split_label(split: Split) -> str:
    """How a report names ``split``: as given, or ``"all"`` for None (every model)."""
    return "all" if split is None else split


def select_split(dataset: ViewpointDataset, split: Split) -> ViewpointDataset:
    """The models of ``split`` (a :data:`~vptoolkit.conventions.Split`: one of ``SPLITS``,
    the alias ``"val"``, or None for every model); never empty."""
    if split is not None and published_split(split) not in SPLITS:
        raise InputError(f"split: unknown split {split!r}, expected one of "
                         f"{', '.join(SPLITS)}, or None for every model")
    selected = dataset if split is None else dataset.split(published_split(split))
    if len(selected) == 0:
        raise InputError(f"{dataset.path.name}: split {split_label(split)!r} has no models")
    return selected


def check_models(dataset: ViewpointDataset) -> int:
    """The number of models to evaluate; an empty dataset is refused, naming its store."""
    if len(dataset) == 0:
        raise InputError(f"{dataset.path.name}: no models to evaluate")
    return len(dataset)


def report_split(dataset: ViewpointDataset, split: str | None) -> str:
    """A report's split: ``split`` as given, else the one split of every model, else ``"all"``."""
    if split is not None:
        return split
    present = set(dataset.splits)
    return present.pop() if len(present) == 1 else "all"
