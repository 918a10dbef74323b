"""What both kinds of evaluation check in their inputs: models, splits, prediction arrays,
messages.

Private to :mod:`vptoolkit.evaluate`: :mod:`~vptoolkit.evaluate.scores` (one
direction per model and measure) and :mod:`~vptoolkit.evaluate.coverage`
(view sets) read predictions the same way and word their errors alike.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.conventions import SPLITS
from vptoolkit.data import ViewpointDataset
from vptoolkit.dataset.store.schema import published_split
from vptoolkit.errors import InputError
from vptoolkit.sphere import is_zero_length

EVALUATION_SPLITS = (*SPLITS, "all")
"""Splits an evaluation may select: the published ones, or ``"all"``."""

_MAX_LISTED = 3  # names quoted in an error message before "..."


def quoted(names: Sequence[str]) -> str:
    """The first few names, quoted, then ``...`` if there are more."""
    listed = ", ".join(repr(name) for name in names[:_MAX_LISTED])
    return listed + (", ..." if len(names) > _MAX_LISTED else "")


def counted(n: int, singular: str, plural: str) -> str:
    """``n`` and the noun in the right number: ``1 name``, ``2 names``."""
    return f"{n} {singular if n == 1 else plural}"


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


def select_split(dataset: ViewpointDataset, split: str) -> ViewpointDataset:
    """The models of ``split`` (a name of ``EVALUATION_SPLITS`` or an alias); never empty."""
    split = published_split(split)
    if split not in EVALUATION_SPLITS:
        raise InputError(f"split: unknown split {split!r}, expected one of "
                         f"{', '.join(EVALUATION_SPLITS)}")
    selected = dataset if split == "all" else dataset.split(split)
    if len(selected) == 0:
        raise InputError(f"{dataset.path.name}: split {split!r} has no models")
    return selected


def check_models(dataset: ViewpointDataset) -> int:
    """The number of models to evaluate; an empty dataset is refused, naming its store."""
    if len(dataset) == 0:
        raise InputError(f"{dataset.path.name}: no models to evaluate")
    return len(dataset)


def split_label(dataset: ViewpointDataset, split: str | None) -> str:
    """A report's split: ``split`` as given, else the one split of every model, else ``"all"``."""
    if split is not None:
        return split
    present = set(dataset.splits)
    return present.pop() if len(present) == 1 else "all"
