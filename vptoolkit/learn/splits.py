"""Which models of a dataset store a training run uses.

The training split, the validation split and, optionally, some categories
only; ``max_models`` keeps the first models of a split in store order. An
empty choice is an :class:`~vptoolkit.errors.ArgumentError` naming the
argument, which the command line says with its option.
"""

from __future__ import annotations

from collections.abc import Sequence

from vptoolkit.data import ViewpointDataset
from vptoolkit.errors import ArgumentError

__all__ = ["select_categories", "select_models"]


def _split(dataset: ViewpointDataset, split: str, max_models: int | None,
           what: str) -> tuple[ViewpointDataset, int]:
    """A split and how many of its models (the first, in store order) to use."""
    subset = dataset.split(split)
    if len(subset) == 0:
        hint = ("; choose another with {argument} (\"train\" for a tiny dataset)"
                if what == "val_split" else "")
        raise ArgumentError(f"{{argument}}: split {split!r} of {dataset.path.name} has no "
                            f"models{hint}", what)
    return subset, len(subset) if max_models is None else min(len(subset), max_models)


def select_categories(dataset: ViewpointDataset,
                      categories: Sequence[str] | str | None) -> list[str] | None:
    """The chosen categories, sorted and checked against ``dataset`` (None: all of them)."""
    if categories is None:
        return None
    if isinstance(categories, str):
        categories = [categories]
    chosen = sorted({str(name) for name in categories})
    unknown = sorted(set(chosen) - set(dataset.categories))
    if not chosen or unknown:
        raise ArgumentError(f"{{argument}}: {unknown or 'none given'} not in "
                            f"{dataset.path.name} (it has {sorted(set(dataset.categories))})",
                            "categories")
    return chosen


def select_models(dataset: ViewpointDataset, split: str, categories: list[str] | None,
                  max_models: int | None, what: str) -> tuple[ViewpointDataset, int]:
    """A split (restricted to ``categories``) and how many of its models to use."""
    subset, count = _split(dataset, split, max_models, what)
    if categories is None:
        return subset, count
    keep = [name for name, category in zip(subset.names, subset.categories)
            if category in categories]
    if not keep:
        raise ArgumentError(f"{{argument}}: split {split!r} of {dataset.path.name} has no "
                            f"models of {categories}", what)
    chosen = subset.subset(keep)
    return chosen, len(chosen) if max_models is None else min(len(chosen), max_models)
