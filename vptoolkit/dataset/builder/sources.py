"""Where a build's models come from: mesh and point-cloud files, their ids, categories, splits.

Source layout (:func:`discover_models`)
    A ModelNet40-style tree ``<category>/<train|test>/<name>.off`` or any
    folder of meshes and point clouds: a model's category is the name of its parent folder
    (its grandparent when the parent is ``train`` or ``test``), and files
    directly in the source folder get the source folder's name. Every suffix
    :data:`vptoolkit.io.MODEL_SUFFIXES` names is read (a file holding points
    only is a point cloud, measured on its points); hidden files and
    folders (``.name``) are skipped.

Names (:func:`~vptoolkit.conventions.model_name`)
    A model's name is its path relative to the source folder without the
    suffix, its parts joined by :data:`~vptoolkit.conventions.NAME_SEPARATOR`
    (``__``): ``SRC/teapot.stl`` is ``teapot``, ``SRC/a/teapot.stl`` is
    ``a__teapot``, ``SRC/chair/train/chair_0001.off`` is
    ``chair__train__chair_0001``. So ``a/teapot.stl`` and ``b/teapot.stl``
    are two models, and the files directly in the source folder keep their
    stems as names. Files that still give one name (``a.off`` and ``a.obj``,
    or ``a/b.off`` and ``a__b.off``) are all recorded as failures
    (:func:`split_duplicates`), as nothing tells which one is meant.

Splits (:func:`assign_split`)
    80/10/10 from the split seed and ``category/name`` alone, so adding a
    model never moves another; a model under ``test/`` stays test.

Subsets (:func:`spread_over_categories`)
    ``max_models`` takes models in turn from each category (sorted), each
    category's in the sorted model order, so a subset covers the categories
    and is the same on every run over the same source.

Seeds (:func:`model_seed`)
    The point sample of a model is seeded from the split seed and its
    ``category/name``, never from a worker or queue position.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from vptoolkit.checks import as_path, check_int
from vptoolkit.conventions import model_name
from vptoolkit.errors import InputError
from vptoolkit.files import check_path_part
from vptoolkit.io import MODEL_SUFFIXES, find_model_files

__all__ = [
    "SPLIT_FRACTIONS",
    "SourceModel",
    "assign_split",
    "discover_models",
    "model_seed",
    "models_outside",
    "split_duplicates",
    "split_of",
    "spread_over_categories",
]

SPLIT_FRACTIONS: dict[str, float] = {"train": 0.8, "val": 0.1, "test": 0.1}
"""Fractions of the train/val/test split (SCHEMA.md)."""

_FOLDER_SPLITS = ("train", "test")


@dataclass(frozen=True)
class SourceModel:
    """One model file (a mesh or a point cloud) found in a source folder.

    Attributes
    ----------
    path : Path
        Absolute path of the file.
    source : str
        Path relative to the source folder, with ``/`` separators.
    category : str
        Category (parent folder name, see :func:`discover_models`).
    name : str
        The model's name, :func:`~vptoolkit.conventions.model_name` of ``source``.
    folder_split : str or None
        ``"train"`` or ``"test"`` when the file sits in a folder of that
        name (ModelNet layout), else None.
    """

    path: Path
    source: str
    category: str
    name: str
    folder_split: str | None = None

    @property
    def model_id(self) -> str:
        """Stable id ``category/name`` used for the split and the seed."""
        return f"{self.category}/{self.name}"


# --------------------------------------------------------------------------- discovery


def discover_models(
    src: str | os.PathLike[str], categories: Iterable[str] | None = None
) -> list[SourceModel]:
    """Find the model files (meshes and point clouds) under a source folder.

    Parameters
    ----------
    src : str or os.PathLike
        A ModelNet40-style tree (``<category>/<train|test>/<name>.off``) or
        any folder of meshes. A file's category is its parent folder's name,
        or its grandparent's when the parent is ``train`` or ``test``; files
        directly in ``src`` get ``src``'s own name. Files whose suffix is not
        in :data:`~vptoolkit.io.MODEL_SUFFIXES` and hidden files and
        folders (name starting with ``.``) are ignored.
    categories : iterable of str, optional
        Keep only these categories (default: all).

    Returns
    -------
    list of SourceModel
        Sorted by ``(category, name, source)``. Duplicate names are kept
        here; :func:`~vptoolkit.dataset.builder.run.build_dataset` records them as failures.

    Raises
    ------
    InputError
        If ``src`` does not exist or is not a folder, holds no mesh files,
        or a requested category has no mesh files.
    """
    root = as_path(src, "src")
    if not root.exists():
        raise InputError(f"{root}: source folder does not exist")
    if not root.is_dir():
        raise InputError(f"{root}: source is not a folder")
    root = root.resolve()
    wanted = _check_categories(categories)
    models = [_source_model(root, path) for path in find_model_files(root)]
    if not models:
        raise InputError(
            f"{root}: no mesh files found (looked for {', '.join(MODEL_SUFFIXES)})"
        )
    if wanted is not None:
        found = {model.category for model in models}
        missing = [category for category in wanted if category not in found]
        if missing:
            raise InputError(
                f"categories: no mesh files in {', '.join(missing)} under {root}; "
                f"found {', '.join(sorted(found))}"
            )
        models = [model for model in models if model.category in wanted]
    return sorted(models, key=lambda model: (model.category, model.name, model.source))


def _source_model(root: Path, path: Path) -> SourceModel:
    parents = path.relative_to(root).parts[:-1]
    folder_split = None
    if parents and parents[-1] in _FOLDER_SPLITS:
        folder_split = parents[-1]
        parents = parents[:-1]
    category = parents[-1] if parents else root.name
    return SourceModel(
        path=path,
        source=path.relative_to(root).as_posix(),
        category=category,
        name=model_name(path.relative_to(root).as_posix()),
        folder_split=folder_split,
    )



def _check_categories(categories: Iterable[str] | None) -> list[str] | None:
    if categories is None:
        return None
    if isinstance(categories, (str, bytes)):
        raise InputError(
            f"categories: expected a list of names, got the string {categories!r} "
            "(split it on commas first)"
        )
    try:
        names = list(categories)
    except TypeError as err:
        raise InputError(
            f"categories: expected a list of names, got {type(categories).__name__}"
        ) from err
    if not names or not all(isinstance(name, str) and name for name in names):
        raise InputError(f"categories: expected non-empty category names, got {names!r}")
    return names


def split_duplicates(
    models: Sequence[SourceModel],
) -> tuple[list[SourceModel], list[dict[str, str]]]:
    """Separate the models a store can hold from duplicates and unusable names (failures).

    A name must be unique within the dataset (SCHEMA.md), so ``chair/a.off``
    and ``chair/a.obj`` clash (both ``chair__a``), as do ``chair/a.off`` and
    ``chair__a.off``;
    and a name or category must be usable as a path part
    (:func:`vptoolkit.files.check_path_part`: a file stem holding a backslash
    or a control character is legal on Linux but not in a store).
    """
    by_name: dict[str, list[SourceModel]] = {}
    for model in models:
        by_name.setdefault(model.name, []).append(model)
    unique: list[SourceModel] = []
    failures: list[dict[str, str]] = []
    for model in models:
        try:
            check_path_part(model.category, f"{model.source}: category")
            check_path_part(model.name, f"{model.source}: model name")
        except InputError as err:
            failures.append(_failure(model, str(err)))
            continue
        group = by_name[model.name]
        if len(group) == 1:
            unique.append(model)
            continue
        sources = ", ".join(sorted(other.source for other in group))
        failures.append(
            _failure(
                model,
                f"{model.source}: duplicate model name {model.name!r} "
                f"({len(group)} files: {sources}); names must be unique, rename all but one",
            )
        )
    return unique, failures


def _failure(model: SourceModel, reason: str) -> dict[str, str]:
    """A failure record (SCHEMA.md): ``{"source", "category", "reason"}``."""
    return {"source": model.source, "category": model.category, "reason": reason}


def models_outside(models: list[SourceModel], out_dir: Path) -> list[SourceModel]:
    """Drop files inside the build folder, in case it lies within the source folder."""
    out_resolved = out_dir.resolve()
    return [model for model in models if not model.path.is_relative_to(out_resolved)]


def spread_over_categories(models: Sequence[SourceModel], n: int) -> list[SourceModel]:
    """The first ``n`` models taking one from each category in turn, in discovery order.

    Categories are visited in sorted order and each one's models in the order
    of ``models`` (sorted by :func:`discover_models`): with categories ``a``
    (models a1, a2, a3) and ``b`` (b1), ``n=3`` takes a1, b1, then a2, and
    returns them in the order of ``models``: a1, a2, b1.
    """
    n = check_int(n, "max_models", minimum=1)
    by_category: dict[str, list[SourceModel]] = {}
    for model in models:
        by_category.setdefault(model.category, []).append(model)
    queues = [by_category[category] for category in sorted(by_category)]
    chosen: set[int] = set()
    for depth in range(max((len(queue) for queue in queues), default=0)):
        for queue in queues:
            if len(chosen) == n:
                break
            if depth < len(queue):
                chosen.add(id(queue[depth]))
    return [model for model in models if id(model) in chosen]


# --------------------------------------------------------------------------- splits and seeds


def assign_split(
    category: str, name: str, *, seed: int, folder_split: str | None = None
) -> str:
    """Split of one model, from the seed and its ``category/name`` alone.

    ``u`` is the first 8 bytes of ``SHA-256(f"{seed}:{category}/{name}")``
    read as a big-endian unsigned integer, divided by ``2**64`` (so
    ``u = int(hexdigest[:16], 16) / 2**64``). Without a folder split,
    ``u < 0.8`` is train, ``u < 0.9`` val, else test. In a ModelNet-style
    tree a model under ``test/`` is always test, and one under ``train/``
    is val when ``u >= 0.8 / 0.9`` (one ninth of them), else train.

    Parameters
    ----------
    category, name : str
        The model's category and name.
    seed : int
        Split seed.
    folder_split : {"train", "test"} or None
        The ModelNet folder the file sits in (default: None).

    Returns
    -------
    str
        ``"train"``, ``"val"`` or ``"test"``.

    Raises
    ------
    InputError
        If an argument has the wrong type or ``folder_split`` is unknown.

    Examples
    --------
    >>> assign_split("chair", "chair_0001", seed=0, folder_split="test")
    'test'
    """
    for value, what in ((category, "category"), (name, "name")):
        if not isinstance(value, str) or not value:
            raise InputError(f"{what}: expected a non-empty string, got {value!r}")
    seed = check_int(seed, "seed", minimum=None)
    if folder_split not in (None, *_FOLDER_SPLITS):
        raise InputError(f"folder_split: expected 'train', 'test' or None, got {folder_split!r}")
    if folder_split == "test":
        return "test"
    u = _unit_hash(f"{seed}:{category}/{name}")
    train = SPLIT_FRACTIONS["train"]
    if folder_split == "train":
        return "val" if u >= train / (train + SPLIT_FRACTIONS["val"]) else "train"
    if u < train:
        return "train"
    return "val" if u < train + SPLIT_FRACTIONS["val"] else "test"


def split_of(model: SourceModel, seed: int) -> str:
    """Split of a found model (:func:`assign_split` of its category, name and folder)."""
    return assign_split(model.category, model.name, seed=seed, folder_split=model.folder_split)


def _unit_hash(text: str) -> float:
    """First 8 bytes of SHA-256(text), big-endian, divided by 2**64: a float in [0, 1)."""
    digest = hashlib.sha256(text.encode("utf-8")).digest()
    return int.from_bytes(digest[:8], "big") / 2**64


def model_seed(split_seed: int, model_id: str) -> int:
    """Point-sampling seed of one model: from the base seed and its stable id only."""
    digest = hashlib.sha256(f"{split_seed}:points:{model_id}".encode()).digest()
    return int.from_bytes(digest[:8], "big")

