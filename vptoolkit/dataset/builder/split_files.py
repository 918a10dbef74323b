"""Published splits read from a file: a ``name,split`` CSV or the paper's ``small.txt``.

The paper's rule (:func:`paper_split`)
    The authors' ``small.txt`` lists one model per line, e.g.
    ``objfiles/airplane/train/airplane_0001.obj`` (the ``objfiles/`` prefix
    is optional). ``index`` counts the lines whose category passes the
    category filter (lines of other categories do not advance it); a model is
    train when ``index % 10`` is 0-7, validation at 8 and test at 9. The
    ``train``/``test`` folder in the line is ModelNet's own and is not the
    paper's split. A line names the model that ``build-dataset`` names from
    the same path under its source folder (:attr:`ListedModel.model_name`,
    ``airplane__train__airplane_0001``), so the list places the models of a
    build from the ``objfiles`` folder or a ModelNet40 tree.

CSV (:func:`read_split_file`, :func:`write_split_file`)
    A header line ``name,split`` then one model per line; the split is one of
    ``train``, ``validation`` (or ``val``) and ``test``.

A split stratified by category (:func:`class_split`)
    Within each category the models are ordered by
    ``SHA-256(f"{seed}:{category}/{name}")`` and the first
    ``max(1, round(fraction * n))`` become validation (none where the
    category has a single model), the rest train; so every category with two
    or more models is seen in both splits, and the split of a model depends
    on its category's members and the seed only, never on file order.

Needs the standard library only.
"""

from __future__ import annotations

import csv
import hashlib
import io
import os
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from vptoolkit.checks import short_repr
from vptoolkit.conventions import NAME_SEPARATOR, SPLITS
from vptoolkit.dataset.store.schema import published_split
from vptoolkit.errors import InputError
from vptoolkit.files import check_path_part, write_text_atomic

__all__ = [
    "PAPER_CATEGORIES",
    "ListedModel",
    "class_split",
    "paper_split",
    "paper_splits",
    "read_model_list",
    "read_split_file",
    "split_file_problem",
    "write_split_file",
]

PAPER_CATEGORIES = ("airplane", "bench", "bottle", "car", "chair", "sofa", "table", "toilet")
"""The eight ModelNet40 categories of the paper's experiments."""

_PREFIX = "objfiles/"
_QUOTED_CHARS = 80  # an error quotes at most this much of a line, ending in "..." when cut
_FOLDERS = ("train", "test")


@dataclass(frozen=True)
class ListedModel:
    """One line of a ``small.txt`` model list.

    Attributes
    ----------
    category : str
        The category folder, e.g. ``"airplane"``.
    folder : str
        ModelNet's ``"train"`` or ``"test"`` folder (not the paper's split).
    name : str
        File stem, the model's name.
    line : int
        1-based line number in the file.
    """

    category: str
    folder: str
    name: str
    line: int

    @property
    def model_name(self) -> str:
        """The name a build gives the file: its path, parts joined by ``__``.

        ``<category>__<folder>__<name>``: the name of
        :func:`~vptoolkit.dataset.builder.sources.model_name` for the line's
        path under ``objfiles/``.
        """
        return NAME_SEPARATOR.join((self.category, self.folder, self.name))

    @property
    def stem_path(self) -> str:
        """``<category>/<folder>/<name>``: where each of the model's files lies under a folder."""
        return f"{self.category}/{self.folder}/{self.name}"


def paper_split(index: int) -> str:
    """The paper's split of the model at ``index`` among the filtered lines.

    Examples
    --------
    >>> [paper_split(i) for i in (0, 7, 8, 9, 10)]
    ['train', 'train', 'validation', 'test', 'train']
    """
    rest = index % 10
    return "train" if rest < 8 else ("validation" if rest == 8 else "test")


def read_model_list(path: str | os.PathLike[str]) -> list[ListedModel]:
    """Read the lines of a ``small.txt`` model list.

    Parameters
    ----------
    path : path-like
        The file; blank lines are ignored (they do not advance the index).

    Returns
    -------
    list of ListedModel
        In file order.

    Raises
    ------
    InputError
        If the file cannot be read or a line is not
        ``[objfiles/]<category>/<train|test>/<name>.obj``; the message names
        the file and the line.
    """
    source = Path(path)
    try:
        text = source.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{source}: cannot read the model list ({err})") from err
    listed = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        listed.append(_listed_model(source, number, line))
    return listed


def _listed_model(source: Path, number: int, line: str) -> ListedModel:
    relative = line[len(_PREFIX):] if line.startswith(_PREFIX) else line
    parts = PurePosixPath(relative).parts
    if (len(parts) != 3 or parts[1] not in _FOLDERS or not parts[2].lower().endswith(".obj")
            or len(parts[2]) <= len(".obj")):
        raise InputError(
            f"{source}: line {number} is {short_repr(line, _QUOTED_CHARS)}, expected "
            "objfiles/<category>/<train|test>/<name>.obj"
        )
    return ListedModel(category=parts[0], folder=parts[1], name=parts[2][: -len(".obj")],
                       line=number)


def paper_splits(listed: Sequence[ListedModel],
                 categories: Iterable[str] | None = None) -> list[tuple[ListedModel, str]]:
    """The paper's split of each listed model whose category passes the filter.

    Parameters
    ----------
    listed : sequence of ListedModel
        The lines of ``small.txt`` in file order (:func:`read_model_list`).
    categories : iterable of str, optional
        Keep only these categories (default: all); the index counts the kept
        lines only.

    Returns
    -------
    list of (ListedModel, str)
        The kept lines in file order with their split
        (:func:`paper_split` of their position among the kept lines).
    """
    wanted = None if categories is None else set(categories)
    kept = [model for model in listed if wanted is None or model.category in wanted]
    return [(model, paper_split(index)) for index, model in enumerate(kept)]


def read_split_file(path: str | os.PathLike[str],
                    categories: Iterable[str] | None = None) -> dict[str, str]:
    """Read a published split: a ``name,split`` CSV or the paper's ``small.txt``.

    A file whose first line is the header ``name,split`` is a CSV; any other
    is read as a ``small.txt`` model list with the paper's rule over the lines
    whose category is in ``categories``.

    Parameters
    ----------
    path : path-like
        The split file.
    categories : iterable of str, optional
        The category filter of the paper's rule (default: every line counts);
        ignored for a CSV.

    Returns
    -------
    dict
        Model name to split, one of :data:`~vptoolkit.conventions.SPLITS`:
        a CSV's names as written, a ``small.txt`` line's
        :attr:`ListedModel.model_name`.

    Raises
    ------
    InputError
        If the file cannot be read, a line is malformed (a CSV cell over
        131,072 characters included), a split is unknown or a name is listed
        twice; the message names the file and the line and quotes at most 80
        characters of it.
    """
    source = Path(path)
    try:
        text = source.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{source}: cannot read the split file ({err})") from err
    first = text.lstrip("\ufeff").split("\n", 1)[0].strip().replace(" ", "").lower()
    if first == "name,split":
        return _read_csv(source, text.lstrip("\ufeff"))
    splits: dict[str, str] = {}
    for model, split in paper_splits(read_model_list(source), categories):
        if model.model_name in splits:
            raise InputError(f"{source}: line {model.line} lists "
                             f"{short_repr(model.stem_path, _QUOTED_CHARS)} a second time")
        splits[model.model_name] = split
    return splits


def _read_csv(source: Path, text: str) -> dict[str, str]:
    rows = csv.reader(io.StringIO(text))
    try:
        return _csv_splits(source, rows)
    except csv.Error as err:  # e.g. a cell longer than csv's field limit of 131,072 characters
        raise InputError(f"{source}: line {rows.line_num} cannot be read as CSV ({err})") from err


def _csv_splits(source: Path, rows: Iterator[list[str]]) -> dict[str, str]:
    """The splits of the rows of a ``name,split`` CSV, its header first."""
    splits: dict[str, str] = {}
    next(rows)
    for number, row in enumerate(rows, start=2):
        if not row or all(not cell.strip() for cell in row):
            continue
        if len(row) != 2 or not row[0].strip():
            raise InputError(f"{source}: line {number} is "
                             f"{short_repr(','.join(row), _QUOTED_CHARS)}, expected name,split")
        name, split = row[0].strip(), published_split(row[1].strip().lower())
        if split not in SPLITS:
            raise InputError(
                f"{source}: line {number}: split {short_repr(row[1].strip(), _QUOTED_CHARS)} "
                f"is not one of {', '.join(SPLITS)} (or val)"
            )
        if name in splits:
            raise InputError(f"{source}: line {number} lists "
                             f"{short_repr(name, _QUOTED_CHARS)} a second time")
        splits[name] = split
    return splits


def class_split(models: Iterable[tuple[str, str]], *, fraction: float = 0.1,
                seed: int = 0) -> dict[str, str]:
    """Split models into train and validation within each category.

    Parameters
    ----------
    models : iterable of (str, str)
        ``(category, name)`` of every model; names must be unique.
    fraction : float, optional
        Share of each category that goes to validation, in (0, 1)
        (default 0.1); at least one model of each category with two or more.
    seed : int, optional
        Seed of the order within each category (default 0).

    Returns
    -------
    dict
        Model name to ``"train"`` or ``"validation"``, in the order given.

    Raises
    ------
    InputError
        If ``fraction`` is outside (0, 1) or a name occurs twice.

    Examples
    --------
    >>> split = class_split([("cup", "a"), ("cup", "b"), ("jet", "c")], fraction=0.1)
    >>> sorted(split.values())
    ['train', 'train', 'validation']
    """
    if not isinstance(fraction, (int, float)) or not 0.0 < fraction < 1.0:
        raise InputError(f"fraction: expected a number in (0, 1), got {fraction!r}")
    by_category: dict[str, list[str]] = {}
    order: dict[str, None] = {}
    for category, name in models:
        if name in order:
            raise InputError(f"models: the name {name!r} occurs twice; names must be unique")
        by_category.setdefault(category, []).append(name)
        order[name] = None
    validation: set[str] = set()
    for category, names in by_category.items():
        if len(names) < 2:
            continue
        n_val = min(len(names) - 1, max(1, round(fraction * len(names))))
        ranked = sorted(names, key=lambda name: hashlib.sha256(
            f"{seed}:{category}/{name}".encode()).hexdigest())
        validation.update(ranked[:n_val])
    return {name: "validation" if name in validation else "train" for name in order}


_FORMULA_STARTS = ("=", "+", "-", "@")
"""First characters that make a spreadsheet read a CSV cell as a formula."""


def split_file_problem(category: str, name: str) -> str | None:
    """Why a model cannot be listed in a split file, or None when it can.

    Its name and category must be usable in a store (as build-dataset checks:
    :func:`vptoolkit.files.check_path_part`, no control character such as a
    line break or a tab); the name must have no space at either end (the
    reader strips cells, so ``" lead"`` would not find ``" lead.off"``) and
    must not start with ``=``, ``+``, ``-`` or ``@``, which a spreadsheet
    opening the CSV would run as a formula.
    """
    try:
        check_path_part(category, "category")
        check_path_part(name, "name")
    except InputError as err:
        return str(err)
    if name != name.strip():
        return f"name {name!r} has a space at one end, which a split file cannot hold"
    if name.startswith(_FORMULA_STARTS):
        return f"name {short_repr(name, _QUOTED_CHARS)} starts with a spreadsheet formula character"
    return None


def write_split_file(path: str | os.PathLike[str], splits: dict[str, str]) -> Path:
    """Write a ``name,split`` CSV that :func:`read_split_file` reads back, sorted by name.

    Parameters
    ----------
    path : path-like
        The file to write (atomically: a reader never sees half of it).
    splits : dict
        Model name to a split of :data:`~vptoolkit.conventions.SPLITS`.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    InputError
        For a split not of :data:`~vptoolkit.conventions.SPLITS` or a name
        :func:`split_file_problem` refuses.
    """
    unknown = sorted({split for split in splits.values() if split not in SPLITS})
    if unknown:
        raise InputError(f"splits: {', '.join(unknown)} is not one of {', '.join(SPLITS)}")
    for name in splits:
        problem = split_file_problem("category", name)
        if problem is not None:
            raise InputError(f"splits: {problem}")
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["name", "split"])
    for name in sorted(splits):
        writer.writerow([name, splits[name]])
    return write_text_atomic(path, buffer.getvalue())
