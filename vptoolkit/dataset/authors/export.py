"""Writing a store in the paper authors' released tree: :func:`export_authors`.

The layout and its measure folders are those of :mod:`vptoolkit.dataset.authors.importer`;
this writes them so that the authors' training code can read our data. The tree has a
folder for each of the paper's four measures only (VE, VR, VKL, VMI): a store holding
them (in any order, among others) is exported with those four; one lacking any of them
is refused.
"""

from __future__ import annotations

import io
import os
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import as_path, check_bool
from vptoolkit.conventions import N_VIEWS, SPLITS
from vptoolkit.dataset.authors.importer import AUTHORS_FOLDERS, MODEL_LIST, VIEW_TOLERANCE
from vptoolkit.dataset.builder.split_files import paper_split
from vptoolkit.dataset.store.schema import published_split
from vptoolkit.errors import InputError
from vptoolkit.files import (
    check_path_part,
    errors_named,
    held,
    named_os_error,
    remove_stale_partials,
    temporary_prefix,
)
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.progress import progress_bar
from vptoolkit.sphere import fibonacci_sphere

if TYPE_CHECKING:
    from vptoolkit.dataset.store.reader import StoreReader

__all__ = ["ExportResult", "export_authors", "order_for_paper_rule"]


@dataclass(frozen=True)
class ExportResult:
    """Outcome of :func:`export_authors`.

    Attributes
    ----------
    path : Path
        The tree written (``OUT``, holding ``small.txt``).
    n_models : int
        Models written.
    mismatched : tuple of str
        Models whose split the paper's rule over the whole ``small.txt`` does
        not reproduce (the store's split counts do not fit 8:1:1 slots).
    n_meshless : int
        Models without a stored mesh, whose ``.obj`` is not written.
    n_unseen_values : int
        Raw values that were NaN (a view that sees nothing), written as the
        worst value of their measure, as the authors' files hold no NaN.
    """

    path: Path
    n_models: int
    mismatched: tuple[str, ...] = ()
    n_meshless: int = 0
    n_unseen_values: int = 0


def _text(array: NDArray[Any], fmt: str) -> bytes:
    buffer = io.BytesIO()
    np.savetxt(buffer, array, fmt=fmt, delimiter=",")
    return buffer.getvalue()


def _folder_of(record: dict[str, Any]) -> str:
    """ModelNet's train/test folder from the record's source path, else from its split."""
    parts = PurePosixPath(str(record.get("source", ""))).parts[:-1]
    for part in reversed(parts):
        if part in ("train", "test"):
            return part
    return "test" if published_split(record["split"]) == "test" else "train"


def order_for_paper_rule(names_and_splits: Sequence[tuple[str, str]]) -> tuple[list[str],
                                                                                list[str]]:
    """Order models so the paper's rule over the whole list gives each its split where it can.

    Parameters
    ----------
    names_and_splits : sequence of (str, str)
        Each model's name and split, in the order to keep within a split.

    Returns
    -------
    order : list of str
        The names in list order: position ``i`` takes the next model of
        ``paper_split(i)``, or, when that split has none left, of the split
        with the most left.
    mismatched : list of str
        The names whose position gives another split than theirs.
    """
    queues: dict[str, list[str]] = {split: [] for split in SPLITS}
    for name, split in names_and_splits:
        queues[published_split(split)].append(name)
    for queue in queues.values():
        queue.reverse()
    order, mismatched = [], []
    for index in range(len(names_and_splits)):
        wanted = paper_split(index)
        if queues[wanted]:
            order.append(queues[wanted].pop())
            continue
        fallback = max(SPLITS, key=lambda split: (len(queues[split]), -SPLITS.index(split)))
        name = queues[fallback].pop()
        order.append(name)
        mismatched.append(name)
    return order, mismatched


def export_authors(dataset: str | os.PathLike[str], out: str | os.PathLike[str], *,
                   progress: bool = False) -> ExportResult:
    """Write a store in the authors' tree, so their training code can read it.

    Parameters
    ----------
    dataset : path-like
        A store, a build folder or a release folder (as :func:`vptoolkit.data.open_dataset`
        takes); it must have 1000 views in the order of
        :func:`~vptoolkit.sphere.fibonacci_sphere` and hold the paper's four
        measures (:data:`~vptoolkit.measures.registry.PAPER_MEASURES`; the columns of any
        other measure are not written).
    out : path-like
        The data set folder to write (``data/<set>``): new, or an empty
        folder. It is written under a temporary sibling name
        (``.<out>.<random>.partial``) and renamed into place at the end; such
        siblings that a killed export left are removed after a successful
        one, and an error names ``out``, never the temporary folder.
    progress : bool
        Show a progress bar on stderr (default: False).

    Returns
    -------
    ExportResult
        The tree, the count, and where the paper's rule cannot reproduce the
        store's split.

    Raises
    ------
    InputError
        If the store cannot be read, its views are not the authors' 1000, it
        lacks one of the paper's four measures, a model's name or category
        cannot be a file or folder name (:func:`~vptoolkit.files.check_path_part`),
        or ``out`` is not new or empty.
    OSError
        If writing fails (e.g. a full disk or a read-only folder); its
        ``filename`` is ``out``.

    Notes
    -----
    Points, normals, views and raw values are written with ``%.9g`` for
    float32 and ``%.17g`` for the float64 views, so an import reads
    the stored float32 arrays back exactly. ``small.txt`` lists the models in
    the order of :func:`order_for_paper_rule` over the store's splits (within
    a split by category and name): the paper's rule over all its lines
    reproduces every split it can, unless the import filters categories.
    The ``best/`` files hold the raw maximum, the raw minimum and the best
    view's direction.
    """
    from vptoolkit.dataset.store.containers import find_store
    from vptoolkit.dataset.store.reader import open_store

    target = as_path(out, "out")
    progress = check_bool(progress, "progress")
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise InputError(f"{target}: exists and is not an empty folder")
    if not target.parent.is_dir():
        raise InputError(f"{target}: output folder {target.parent} does not exist")
    with open_store(find_store(as_path(dataset, "dataset"))) as data:
        lacking = [measure for measure in PAPER_MEASURES if measure not in data.measures]
        if lacking:
            raise InputError(
                f"{data.path}: the authors' tree holds {', '.join(PAPER_MEASURES)}; this store "
                f"records {', '.join(data.measures)}, without {', '.join(lacking)}")
        views = np.asarray(data.array("views"), dtype=np.float64)
        ours = fibonacci_sphere(N_VIEWS)
        if views.shape != ours.shape or np.abs(views - ours).max() > VIEW_TOLERANCE:
            raise InputError(
                f"{data.path}: {len(views)} views that are not the Fibonacci sphere of "
                f"{N_VIEWS}; the authors' layout has exactly those"
            )
        records = data.models()
        order, mismatched = order_for_paper_rule(
            [(r["name"], r["split"]) for r in records]
        )
        stems = {record["name"]: _stem(record, data.path.name) for record in records}
        try:
            temporary = Path(tempfile.mkdtemp(prefix=temporary_prefix(target.name),
                                              suffix=".partial", dir=target.parent))
        except OSError as err:  # e.g. a read-only folder: name OUT, not the hidden folder
            raise named_os_error(err, target) from err
        is_done = False
        try:
            # a full disk or a file too large names OUT, not the hidden folder
            with errors_named(temporary, target), held(temporary):
                n_meshless, n_unseen = _write_tree(temporary, data, order, stems, views,
                                                   progress)
                os.chmod(temporary, 0o777 & ~_umask())
                if target.exists():
                    target.rmdir()
                os.rename(temporary, target)
                is_done = True
        finally:
            if not is_done:
                shutil.rmtree(temporary, ignore_errors=True)
    remove_stale_partials(target.parent, target.name)  # left by a killed earlier export
    return ExportResult(path=target, n_models=len(order), mismatched=tuple(mismatched),
                        n_meshless=n_meshless, n_unseen_values=n_unseen)


def _stem(record: dict[str, Any], store: str) -> str:
    """``<category>/<train|test>/<name>`` of a model of ``store``, from checked parts."""
    name = check_path_part(record["name"], f"{store}: model name")
    category = check_path_part(record["category"], f"{store}: model {name!r}, category")
    return f"{category}/{_folder_of(record)}/{name}"


def _write_tree(root: Path, data: StoreReader, order: Sequence[str], stems: dict[str, str],
                views: NDArray[np.float64], progress: bool) -> tuple[int, int]:
    """Write every file of the tree under ``root``, the models in ``order``.

    ``views`` are the store's, for the best views; the view lists hold the
    Fibonacci sphere itself. Returns the number of models without a mesh and
    of NaN raw values written.
    """
    from vptoolkit.io.obj import obj_bytes

    n_meshless = n_unseen = 0
    columns = [data.measures.index(measure) for measure in PAPER_MEASURES]
    point_list = _text(fibonacci_sphere(N_VIEWS), "%.17g")
    for folder in AUTHORS_FOLDERS.values():
        _write(root / "best_views" / folder / "3D" / "_point_list.txt", point_list)
    row_of = {record["name"]: row for row, record in enumerate(data.models())}
    lines = []
    with progress_bar(total=len(order), description="export", unit="model",
                      enabled=progress) as bar:
        for name in order:
            stem = stems[name]
            lines.append(f"objfiles/{stem}.obj\n")
            entry = data.entry(row_of[name])
            if len(entry.faces):
                _write(root / "objfiles" / f"{stem}.obj",
                       obj_bytes(np.asarray(entry.vertices, dtype=np.float64),
                                 np.asarray(entry.faces, dtype=np.int64), name=name))
            else:
                n_meshless += 1
            points = np.concatenate([entry.points, entry.normals], axis=1)
            _write(root / "pts_unif" / f"{stem}.txt", _text(points, "%.9g"))
            n_unseen += _write_measures(root, stem, entry.quality_raw[:, columns],
                                        entry.quality[:, columns], views)
            bar.update(1)
    _write(root / MODEL_LIST, "".join(lines).encode("utf-8"))
    return n_meshless, n_unseen


def _write_measures(root: Path, stem: str, raw: NDArray[Any], quality: NDArray[Any],
                    views: NDArray[np.float64]) -> int:
    """Write one model's lists and best files; return the NaN values written as the worst.

    ``raw`` and ``quality`` are ``(n_views, 4)``, columns in ``PAPER_MEASURES`` order.
    """
    n_unseen = 0
    for column, measure in enumerate(PAPER_MEASURES):
        folder = AUTHORS_FOLDERS[measure]
        values = np.asarray(raw[:, column], dtype=np.float32)
        unseen = ~np.isfinite(values)
        if unseen.any():
            n_unseen += int(unseen.sum())
            worst = int(np.argmin(np.where(unseen, np.inf, quality[:, column])))
            values = np.where(unseen, values[worst], values)
        _write(root / "best_views" / folder / "3D" / f"{stem}_vq_list.txt",
               _text(values[:, None], "%.9g"))
        best = int(np.argmax(quality[:, column]))
        extremes = _text(np.array([[values.max()], [values.min()]], dtype=np.float32), "%.9g")
        _write(root / "best_views" / folder / "best" / f"{stem}.txt",
               extremes + _text(views[best][:, None], "%.17g"))
    return n_unseen


def _write(path: Path, payload: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(payload)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask

