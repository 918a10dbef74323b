"""The paper authors' released data: :func:`import_authors` and :func:`export_authors`.

The authors' tree (one folder per data set, e.g. ``data/ModelNet40``)::

    small.txt                                            model list (split_files)
    objfiles/<cat>/<folder>/<name>.obj                   meshes
    pts_unif/<cat>/<folder>/<name>.txt                   points: "x,y,z,nx,ny,nz" per line
    best_views/vq<k>/3D/_point_list.txt                  the 1000 views: "x,y,z" per line
    best_views/vq<k>/3D/<cat>/<folder>/<name>_vq_list.txt    1000 raw values, one per line
    best_views/vq<k>/best/<cat>/<folder>/<name>.txt      max, min, best view x, y, z (5 lines)

``<folder>`` is ModelNet's ``train`` or ``test`` folder, not the paper's split
(that is :func:`vptoolkit.dataset.split_files.paper_split` of the line's
position in ``small.txt``). Every file is comma-separated text.

Measures
    ``vq5`` is VE, ``vq4`` VR, ``vq7`` VKL and ``vq8`` VMI
    (:data:`AUTHORS_FOLDERS`, in :data:`~vptoolkit.conventions.MEASURES`
    order); VKL and VMI are lower-is-better. The authors normalise each list
    per model by taking ``max - v`` for VKL and VMI, then ``(v - min) /
    (max - min)``, which is :func:`vptoolkit.measures.normalize_quality`.

Views
    Their views are the Fibonacci sphere of 1000 samples, in the order of
    :func:`vptoolkit.sphere.fibonacci_sphere`; an import refuses a tree whose
    ``_point_list.txt`` differs from it.
"""

from __future__ import annotations

import hashlib
import io
import os
import shutil
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import as_path, check_bool, one_line
from vptoolkit.conventions import MEASURES, N_VIEWS, SPLITS
from vptoolkit.dataset.schema import ModelEntry, published_split
from vptoolkit.dataset.split_files import ListedModel, paper_split, paper_splits, read_model_list
from vptoolkit.dataset.writer import write_dataset
from vptoolkit.errors import InputError, VptoolkitError
from vptoolkit.files import temporary_prefix
from vptoolkit.measures import normalize_quality
from vptoolkit.progress import progress_bar
from vptoolkit.sphere import fibonacci_sphere

__all__ = [
    "AUTHORS_FOLDERS",
    "AUTHORS_RESOLUTION",
    "ExportResult",
    "ImportResult",
    "export_authors",
    "import_authors",
    "order_for_paper_rule",
]

AUTHORS_FOLDERS: dict[str, str] = {"VE": "vq5", "VR": "vq4", "VKL": "vq7", "VMI": "vq8"}
"""The authors' ``best_views/vq<k>`` folder of each measure, in ``MEASURES`` order."""

AUTHORS_RESOLUTION = 1024
"""Side in pixels of the images the authors' measures were rendered at."""

STORE_NAME = "dataset.zarr"
_VIEW_TOLERANCE = 1e-5  # a view of _point_list.txt may differ by this much per coordinate
_MODEL_LIST = "small.txt"


@dataclass(frozen=True)
class ImportResult:
    """Outcome of :func:`import_authors`.

    Attributes
    ----------
    path : Path
        The store written (``OUT/dataset.zarr``).
    n_models : int
        Models imported.
    failures : tuple of dict
        One ``{"source", "category", "reason"}`` per model that was listed but
        could not be imported, in ``small.txt`` order.
    split_counts : dict
        Models per split, over :data:`~vptoolkit.conventions.SPLITS`.
    """

    path: Path
    n_models: int
    failures: tuple[dict[str, str], ...]
    split_counts: dict[str, int] = field(default_factory=dict)

    @property
    def n_failures(self) -> int:
        """Number of failures."""
        return len(self.failures)


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


# --------------------------------------------------------------------------- reading


def _sha256_file(path: Path) -> str:
    hasher = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            hasher.update(block)
    return hasher.hexdigest()


def _read_table(path: Path, columns: int, rows: int | None, what: str) -> NDArray[np.float64]:
    """A comma-separated table of finite floats; InputError naming the file otherwise."""
    if not path.is_file():
        raise InputError(f"{path}: {what} is missing")
    try:
        table = np.loadtxt(path, delimiter=",", dtype=np.float64, ndmin=2)
    except (OSError, ValueError) as err:
        raise InputError(f"{path}: {what} is not comma-separated numbers ({one_line(err)})") \
            from err
    if table.shape[1:] != (columns,) or (rows is not None and table.shape[0] != rows):
        expected = f"{rows if rows is not None else 'n'} lines of {columns} values"
        raise InputError(f"{path}: {what} has shape {table.shape}, expected {expected}")
    if not np.isfinite(table).all():
        raise InputError(f"{path}: {what} holds NaN or infinite values")
    return table


def _check_tree(tree: Path) -> None:
    if not tree.is_dir():
        raise InputError(f"{tree}: not a folder")
    missing = [name for name in (_MODEL_LIST, "pts_unif", "best_views") if not (tree / name).exists()]
    if missing:
        raise InputError(
            f"{tree}: not in the authors' layout (no {', '.join(missing)}); "
            "expected DATA/<set> holding small.txt, objfiles/, pts_unif/ and best_views/"
        )
    views = fibonacci_sphere(N_VIEWS)
    for measure, folder in AUTHORS_FOLDERS.items():
        point_list = tree / "best_views" / folder / "3D" / "_point_list.txt"
        if not point_list.is_file():
            raise InputError(f"{point_list}: missing; the authors' layout has one per measure "
                             f"({measure})")
        theirs = _read_table(point_list, 3, None, "view list")
        if theirs.shape != views.shape:
            raise InputError(f"{point_list}: {len(theirs)} views, expected {N_VIEWS}")
        worst = float(np.abs(theirs - views).max())
        if worst > _VIEW_TOLERANCE:
            row = int(np.abs(theirs - views).max(axis=1).argmax())
            raise InputError(
                f"{point_list}: view {row} differs from the Fibonacci sphere of {N_VIEWS} "
                f"views by {worst:.3g}; the measures would be attached to the wrong views"
            )


@dataclass(frozen=True)
class _Listed:
    """One model to import: its line of small.txt and its split."""

    model: ListedModel
    split: str

    @property
    def source(self) -> str:
        return f"objfiles/{self.model.stem_path}.obj"


class _ImportedEntries(Sequence[ModelEntry]):
    """Entries read from the tree on each access (the writer reads each twice)."""

    def __init__(self, tree: Path, listed: list[_Listed], meshes: bool) -> None:
        self._tree = tree
        self._listed = listed
        self._meshes = meshes

    def __len__(self) -> int:
        return len(self._listed)

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        return _read_model(self._tree, self._listed[index], meshes=self._meshes)


def _read_model(tree: Path, listed: _Listed, *, meshes: bool) -> ModelEntry:
    """Read one model's files into a :class:`ModelEntry`; InputError names a bad file."""
    stem = listed.model.stem_path
    points = _read_table(tree / "pts_unif" / f"{stem}.txt", 6, None, "points file")
    raw = np.empty((N_VIEWS, len(MEASURES)), dtype=np.float64)
    for column, measure in enumerate(MEASURES):
        folder = AUTHORS_FOLDERS[measure]
        values = _read_table(tree / "best_views" / folder / "3D" / f"{stem}_vq_list.txt",
                             1, N_VIEWS, f"{measure} list ({folder})")
        raw[:, column] = values[:, 0]
    quality = normalize_quality(raw)
    best = np.argmax(quality, axis=0).astype(np.int64)
    worst = np.argmin(quality, axis=0).astype(np.int64)
    columns = np.arange(len(MEASURES))
    mesh_file = tree / listed.source
    if meshes:
        from vptoolkit.io import load_mesh

        mesh = load_mesh(mesh_file)
        vertices, faces = mesh.vertices, mesh.faces
        digest = _sha256_file(mesh_file)
    else:
        vertices = np.zeros((0, 3), dtype=np.float32)
        faces = np.zeros((0, 3), dtype=np.int32)
        digest = _sha256_file(tree / "pts_unif" / f"{stem}.txt")
    return ModelEntry(
        name=listed.model.name,
        category=listed.model.category,
        split=listed.split,
        source=listed.source,
        source_sha256=digest,
        points=points[:, :3],
        normals=points[:, 3:],
        quality=quality,
        quality_raw=raw,
        best_index=best,
        best_value=raw[best, columns],
        worst_index=worst,
        worst_value=raw[worst, columns],
        vertices=vertices,
        faces=faces,
    )


def _model_files(tree: Path, listed: _Listed, meshes: bool) -> list[Path]:
    stem = listed.model.stem_path
    files = [tree / "pts_unif" / f"{stem}.txt"]
    files += [tree / "best_views" / AUTHORS_FOLDERS[m] / "3D" / f"{stem}_vq_list.txt"
              for m in MEASURES]
    if meshes:
        files.append(tree / listed.source)
    return files


def _created(tree: Path) -> str:
    """$SOURCE_DATE_EPOCH, else the modification time of small.txt: the same tree, the same bytes."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    try:
        seconds = int(epoch) if epoch else int((tree / _MODEL_LIST).stat().st_mtime)
    except ValueError as err:
        raise InputError(f"SOURCE_DATE_EPOCH: expected whole seconds, got {epoch!r}") from err
    return datetime.fromtimestamp(seconds, timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def import_authors(
    tree: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    categories: Iterable[str] | None = None,
    meshes: bool = True,
    progress: bool = False,
) -> ImportResult:
    """Turn the authors' tree into an ordinary vptoolkit store, ``OUT/dataset.zarr``.

    Parameters
    ----------
    tree : path-like
        One data set of the authors' tree, e.g. ``data/ModelNet40`` (the
        folder holding ``small.txt``).
    out : path-like
        Output folder, new or empty; gets ``dataset.zarr``.
    categories : iterable of str, optional
        Import only these categories (default: all). The paper's split index
        counts only their lines of ``small.txt``, as in the authors' loader,
        so the paper's eight categories
        (:data:`~vptoolkit.dataset.split_files.PAPER_CATEGORIES`) give the
        paper's split.
    meshes : bool
        Read and store ``objfiles/`` (default: True); without, each model
        stores an empty mesh and its ``source_sha256`` is that of its points
        file.
    progress : bool
        Show progress bars on stderr (default: False).

    Returns
    -------
    ImportResult
        The store, the counts per split and the failures.

    Raises
    ------
    InputError
        If ``tree`` is not in the authors' layout (no ``small.txt``,
        ``pts_unif/`` or ``best_views/``, a malformed ``small.txt`` line, a
        view list that is not our Fibonacci sphere), ``out`` is a non-empty
        folder, or a category has no line in ``small.txt``.

    Notes
    -----
    The stored arrays: ``quality_raw`` the authors' values in ``MEASURES``
    order, as read; ``quality`` their per-model normalisation; best and worst
    views recomputed from it; ``points`` and ``normals`` the columns of
    ``pts_unif``; the mesh the ``.obj`` file. A listed model whose file is
    missing or malformed (wrong number of values, NaN, an unreadable mesh, a
    point count unlike the first model's) is a failure with a one-line reason
    and still takes its place in the split index. The root attributes record
    ``provenance``: the measures were imported, not computed, the tree's name,
    and the SHA-256 of small.txt and over every file read.
    """
    root = as_path(tree, "tree")
    out_dir = as_path(out, "out")
    meshes = check_bool(meshes, "meshes")
    progress = check_bool(progress, "progress")
    _check_tree(root)
    wanted = None if categories is None else list(categories)
    if isinstance(categories, str):
        raise InputError(f"categories: expected a list of names, got the string {categories!r}")
    listed_lines = read_model_list(root / _MODEL_LIST)
    if wanted is not None:
        found = {model.category for model in listed_lines}
        missing = [name for name in wanted if name not in found]
        if missing:
            raise InputError(f"{root / _MODEL_LIST}: no lines of the categories "
                             f"{', '.join(missing)}")
    if out_dir.exists() and (not out_dir.is_dir() or any(out_dir.iterdir())):
        raise InputError(f"{out_dir}: exists and is not an empty folder")
    listed = [_Listed(model, split) for model, split in paper_splits(listed_lines, wanted)]

    failures: list[dict[str, str]] = []
    good: list[_Listed] = []
    file_sums: list[str] = []
    n_points: int | None = None
    seen: set[str] = set()
    with progress_bar(total=len(listed), description="read", unit="model",
                      enabled=progress) as bar:
        for item in listed:
            bar.update(1)
            reason = None
            if item.model.name in seen:
                reason = f"{root / _MODEL_LIST}: line {item.model.line} lists " \
                         f"{item.model.name!r} a second time"
            else:
                try:
                    entry = _read_model(root, item, meshes=meshes)
                    count = len(entry.points)
                    if n_points is not None and count != n_points:
                        reason = (f"{root / 'pts_unif' / item.model.stem_path}.txt: {count} "
                                  f"points, the first model has {n_points}")
                except VptoolkitError as err:
                    reason = one_line(err)
                except Exception as err:  # an unforeseen reader error stays one model's failure
                    reason = f"{item.source}: {type(err).__name__}: {one_line(err)}"
            if reason is not None:
                failures.append({"source": item.source, "category": item.model.category,
                                 "reason": reason})
                continue
            n_points = count
            seen.add(item.model.name)
            good.append(item)
            file_sums += [f"{_sha256_file(path)}  {path.relative_to(root).as_posix()}"
                          for path in _model_files(root, item, meshes)]

    good.sort(key=lambda item: (item.model.category, item.model.name))
    files_digest = hashlib.sha256("\n".join(sorted(file_sums)).encode("utf-8")).hexdigest()
    attrs = {
        "resolution": AUTHORS_RESOLUTION,
        "backend": "imported",
        "camera": None,
        "cleaning": {"enabled": False, "max_faces": None, "remesh": False},
        "split_seed": None,
        "split_fractions": {"train": 0.8, "val": 0.1, "test": 0.1},
        "source": root.name,
        "toolkit_version": _toolkit_version(),
        "created": _created(root),
        "provenance": {
            "measures": "imported, not computed",
            "tree": root.name,
            "split_rule": "index % 10 over the category-filtered lines of small.txt: "
                          "0-7 train, 8 validation, 9 test",
            "categories": sorted(wanted) if wanted is not None else None,
            "meshes": meshes,
            "small_txt_sha256": _sha256_file(root / _MODEL_LIST),
            "files_sha256": files_digest,
            "n_files": len(file_sums),
        },
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    store = write_dataset(out_dir / STORE_NAME, _ImportedEntries(root, good, meshes),
                          attrs=attrs, views=fibonacci_sphere(N_VIEWS), failures=failures,
                          progress=progress)
    counts = {split: sum(published_split(item.split) == split for item in good)
              for split in SPLITS}
    return ImportResult(path=store, n_models=len(good), failures=tuple(failures),
                        split_counts=counts)


def _toolkit_version() -> str:
    import vptoolkit

    return vptoolkit.__version__


# --------------------------------------------------------------------------- writing


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
        :func:`~vptoolkit.sphere.fibonacci_sphere`.
    out : path-like
        The data set folder to write (``data/<set>``): new, or an empty
        folder. It is written under a temporary sibling name and renamed into
        place at the end.
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
        If the store cannot be read, its views are not the authors' 1000, or
        ``out`` is not new or empty.

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
    from vptoolkit.dataset.containers import find_store
    from vptoolkit.dataset.reader import open_store
    from vptoolkit.io.obj import obj_bytes

    target = as_path(out, "out")
    progress = check_bool(progress, "progress")
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise InputError(f"{target}: exists and is not an empty folder")
    if not target.parent.is_dir():
        raise InputError(f"{target}: output folder {target.parent} does not exist")
    with open_store(find_store(as_path(dataset, "dataset"))) as data:
        views = np.asarray(data.array("views"), dtype=np.float64)
        ours = fibonacci_sphere(N_VIEWS)
        if views.shape != ours.shape or np.abs(views - ours).max() > _VIEW_TOLERANCE:
            raise InputError(
                f"{data.path}: {len(views)} views that are not the Fibonacci sphere of "
                f"{N_VIEWS}; the authors' layout has exactly those"
            )
        records = data.models()
        order, mismatched = order_for_paper_rule(
            [(r["name"], r["split"]) for r in records]
        )
        row_of = {record["name"]: row for row, record in enumerate(records)}
        temporary = Path(tempfile.mkdtemp(prefix=temporary_prefix(target.name),
                                          suffix=".partial", dir=target.parent))
        is_done = False
        n_meshless = n_unseen = 0
        try:
            point_list = _text(ours, "%.17g")
            for folder in AUTHORS_FOLDERS.values():
                _write(temporary / "best_views" / folder / "3D" / "_point_list.txt", point_list)
            lines = []
            with progress_bar(total=len(order), description="export", unit="model",
                              enabled=progress) as bar:
                for name in order:
                    row = row_of[name]
                    record = records[row]
                    stem = f"{record['category']}/{_folder_of(record)}/{name}"
                    lines.append(f"objfiles/{stem}.obj\n")
                    entry = data.entry(row)
                    if len(entry.faces):
                        _write(temporary / "objfiles" / f"{stem}.obj",
                               obj_bytes(np.asarray(entry.vertices, dtype=np.float64),
                                         np.asarray(entry.faces, dtype=np.int64), name=name))
                    else:
                        n_meshless += 1
                    points = np.concatenate([entry.points, entry.normals], axis=1)
                    _write(temporary / "pts_unif" / f"{stem}.txt", _text(points, "%.9g"))
                    n_unseen += _write_measures(temporary, stem, entry.quality_raw,
                                                entry.quality, views)
                    bar.update(1)
            _write(temporary / _MODEL_LIST, "".join(lines).encode("utf-8"))
            os.chmod(temporary, 0o777 & ~_umask())
            if target.exists():
                target.rmdir()
            os.rename(temporary, target)
            is_done = True
        finally:
            if not is_done:
                shutil.rmtree(temporary, ignore_errors=True)
    return ExportResult(path=target, n_models=len(order), mismatched=tuple(mismatched),
                        n_meshless=n_meshless, n_unseen_values=n_unseen)


def _write_measures(root: Path, stem: str, raw: NDArray[Any], quality: NDArray[Any],
                    views: NDArray[np.float64]) -> int:
    """Write one model's lists and best files; return the NaN values written as the worst."""
    n_unseen = 0
    for column, measure in enumerate(MEASURES):
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
        summary = np.array([values.max(), values.min(), *views[best]], dtype=np.float64)
        _write(root / "best_views" / folder / "best" / f"{stem}.txt",
               _text(summary[:, None], "%.17g"))
    return n_unseen


def _write(path: Path, payload: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(payload)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask

