"""The paper authors' released data: the layout, and :func:`import_authors`.

The authors' tree (one folder per data set, e.g. ``data/ModelNet40``)::

    small.txt                                            model list (split_files)
    objfiles/<cat>/<folder>/<name>.obj                   meshes
    pts_unif/<cat>/<folder>/<name>.txt                   points: "x,y,z,nx,ny,nz" per line
    best_views/vq<k>/3D/_point_list.txt                  the 1000 views: "x,y,z" per line
    best_views/vq<k>/3D/<cat>/<folder>/<name>_vq_list.txt    1000 raw values, one per line
    best_views/vq<k>/best/<cat>/<folder>/<name>.txt      max, min, best view x, y, z (5 lines)

``<folder>`` is ModelNet's ``train`` or ``test`` folder, not the paper's split
(that is :func:`vptoolkit.dataset.builder.split_files.paper_split` of the line's
position in ``small.txt``). Every file is comma-separated text.

Measures
    ``vq5`` is VE, ``vq4`` VR, ``vq7`` VKL and ``vq8`` VMI
    (:data:`AUTHORS_FOLDERS`, in :data:`~vptoolkit.measures.registry.PAPER_MEASURES`
    order); VKL and VMI are lower-is-better. The authors normalise each list
    per model by taking ``max - v`` for VKL and VMI, then ``(v - min) /
    (max - min)``, which is :func:`vptoolkit.measures.quality.normalize_quality`.

Views
    Their views are the Fibonacci sphere of 1000 samples, in the order of
    :func:`vptoolkit.sphere.fibonacci_sphere`; an import refuses a tree whose
    ``_point_list.txt`` differs from it.
"""

from __future__ import annotations

import hashlib
import os
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import as_path, check_bool, one_line
from vptoolkit.conventions import N_VIEWS, SPLITS
from vptoolkit.dataset.builder.split_files import ListedModel, paper_splits, read_model_list
from vptoolkit.dataset.store.entries import LazyEntries
from vptoolkit.dataset.store.schema import (
    ModelEntry,
    normal_length_problem,
    published_split,
)
from vptoolkit.dataset.store.writer import write_dataset
from vptoolkit.errors import InputError, VptoolkitError
from vptoolkit.files import check_path_part, sha256_file, stale_partials
from vptoolkit.measures.quality import normalize_quality
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.progress import progress_bar
from vptoolkit.sphere import fibonacci_sphere

__all__ = [
    "AUTHORS_FOLDERS",
    "AUTHORS_RESOLUTION",
    "ImportResult",
    "import_authors",
]

AUTHORS_FOLDERS: dict[str, str] = {"VE": "vq5", "VR": "vq4", "VKL": "vq7", "VMI": "vq8"}
"""The authors' ``best_views/vq<k>`` folder of each measure, in ``PAPER_MEASURES`` order."""

AUTHORS_RESOLUTION = 1024
"""Side in pixels of the images the authors' measures were rendered at."""

STORE_NAME = "dataset.zarr"
"""The store an import writes in its output folder."""
VIEW_TOLERANCE = 1e-5
"""How far a coordinate of ``_point_list.txt`` may be from ours."""
MODEL_LIST = "small.txt"
"""The model list of a tree."""

_FLOAT32_MAX = float(np.finfo(np.float32).max)


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


# --------------------------------------------------------------------------- reading


def _read_table(path: Path, columns: int, rows: int | None, what: str) -> NDArray[np.float64]:
    """A comma-separated table of finite floats within the float32 range (every value is
    stored as float32); InputError naming the file otherwise."""
    if not path.is_file():
        problem = "not a regular file" if path.exists() else "missing"
        raise InputError(f"{path}: {what} is {problem}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data": said below
            table = np.loadtxt(path, delimiter=",", dtype=np.float64, ndmin=2)
    except (OSError, ValueError) as err:
        raise InputError(f"{path}: {what} is not comma-separated numbers ({one_line(err)})") \
            from err
    if not table.size:
        raise InputError(f"{path}: {what} is empty")
    if table.shape[1:] != (columns,) or (rows is not None and table.shape[0] != rows):
        expected = f"{rows if rows is not None else 'n'} lines of {columns} values"
        raise InputError(f"{path}: {what} has shape {table.shape}, expected {expected}")
    if not np.isfinite(table).all():
        raise InputError(f"{path}: {what} holds NaN or infinite values")
    largest = float(np.abs(table).max())
    if largest > _FLOAT32_MAX:
        raise InputError(f"{path}: {what} holds values beyond the float32 range (up to "
                         f"{largest:.3g}), which cannot be stored")
    return table


def _check_tree(tree: Path) -> None:
    if not tree.is_dir():
        raise InputError(f"{tree}: not a folder")
    missing = [name for name in (MODEL_LIST, "pts_unif", "best_views")
               if not (tree / name).exists()]
    if missing:
        raise InputError(
            f"{tree}: not in the authors' layout (no {', '.join(missing)}); "
            "expected DATA/<set> holding small.txt, objfiles/, pts_unif/ and best_views/"
        )
    if not (tree / MODEL_LIST).is_file():  # a FIFO would block the read for ever
        raise InputError(f"{tree / MODEL_LIST}: not a regular file")
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
        if worst > VIEW_TOLERANCE:
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


def _read_model(tree: Path, listed: _Listed, *, meshes: bool) -> ModelEntry:
    """Read one model's files into a :class:`ModelEntry`; InputError names a bad file."""
    stem = listed.model.stem_path
    points_file = tree / "pts_unif" / f"{stem}.txt"
    points = _read_table(points_file, 6, None, "points file")
    problem = normal_length_problem(points[:, 3:])
    if problem is not None:
        raise InputError(f"{points_file}: points file: {problem}")
    raw = np.empty((N_VIEWS, len(PAPER_MEASURES)), dtype=np.float64)
    for column, measure in enumerate(PAPER_MEASURES):
        folder = AUTHORS_FOLDERS[measure]
        values = _read_table(tree / "best_views" / folder / "3D" / f"{stem}_vq_list.txt",
                             1, N_VIEWS, f"{measure} list ({folder})")
        raw[:, column] = values[:, 0]
    quality = normalize_quality(raw)
    best = np.argmax(quality, axis=0).astype(np.int64)
    worst = np.argmin(quality, axis=0).astype(np.int64)
    columns = np.arange(len(PAPER_MEASURES))
    mesh_file = tree / listed.source
    if meshes:
        from vptoolkit.io import load_mesh

        mesh = load_mesh(mesh_file)
        vertices, faces = mesh.vertices, mesh.faces
        digest = sha256_file(mesh_file)
    else:
        vertices = np.zeros((0, 3), dtype=np.float32)
        faces = np.zeros((0, 3), dtype=np.int32)
        digest = sha256_file(tree / "pts_unif" / f"{stem}.txt")
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
              for m in PAPER_MEASURES]
    if meshes:
        files.append(tree / listed.source)
    return files


def _created(tree: Path) -> str:
    """$SOURCE_DATE_EPOCH, else small.txt's modification time: the same tree, the same bytes."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    try:
        seconds = int(epoch) if epoch else int((tree / MODEL_LIST).stat().st_mtime)
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
        (:data:`~vptoolkit.dataset.builder.split_files.PAPER_CATEGORIES`) give the
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
        ``pts_unif/`` or ``best_views/``, a ``small.txt`` that is not a
        regular file or lists no model, a malformed ``small.txt`` line, a
        view list that is not our Fibonacci sphere), ``out`` is a non-empty
        folder, or a category has no line in ``small.txt``.

    Notes
    -----
    The stored arrays: ``quality_raw`` the authors' values in ``PAPER_MEASURES``
    order, as read; ``quality`` their per-model normalisation; best and worst
    views recomputed from it; ``points`` and ``normals`` the columns of
    ``pts_unif``; the mesh the ``.obj`` file. A listed model whose file is
    missing or malformed (wrong number of values, NaN, values beyond the
    float32 range, normals not of unit length, an unreadable mesh, a point
    count unlike the first model's), or whose category or name cannot be a
    file or folder name (:func:`~vptoolkit.files.check_path_part`, e.g. the
    category ``..`` of ``objfiles/../train/x.obj``), is a failure with a
    one-line reason and still takes its place in the split index. Hidden
    ``.dataset.zarr.*.partial`` staging that a killed import left in ``out``
    does not count as content, and is removed once the store is written.
    The root attributes record ``provenance``: the measures were imported,
    not computed, the tree's name, and the SHA-256 of small.txt and one over
    the files of every imported model.
    """
    root = as_path(tree, "tree")
    out_dir = as_path(out, "out")
    meshes = check_bool(meshes, "meshes")
    progress = check_bool(progress, "progress")
    _check_tree(root)
    root = root.resolve()  # so that "." still names the tree
    if isinstance(categories, str):
        raise InputError(f"categories: expected a list of names, got the string {categories!r}")
    wanted = None if categories is None else list(categories)
    if wanted is not None and (not wanted or not all(isinstance(c, str) and c for c in wanted)):
        raise InputError(f"categories: expected non-empty category names, got {wanted!r}")
    listed_lines = read_model_list(root / MODEL_LIST)
    if not listed_lines:
        raise InputError(f"{root / MODEL_LIST}: lists no models")
    if wanted is not None:
        found = {model.category for model in listed_lines}
        missing = [name for name in wanted if name not in found]
        if missing:
            raise InputError(f"{root / MODEL_LIST}: no lines of the categories "
                             f"{', '.join(missing)}")
    # A store staging folder a killed import left is not content; the write removes it.
    if out_dir.exists() and (not out_dir.is_dir() or set(out_dir.iterdir())
                             - set(stale_partials(out_dir, STORE_NAME))):
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
                reason = f"{root / MODEL_LIST}: line {item.model.line} lists " \
                         f"{item.model.name!r} a second time"
            else:
                try:
                    line = f"{root / MODEL_LIST}: line {item.model.line}"
                    check_path_part(item.model.category, f"{line}: category")
                    check_path_part(item.model.name, f"{line}: model name")
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
            file_sums += [f"{sha256_file(path)}  {path.relative_to(root).as_posix()}"
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
            "small_txt_sha256": sha256_file(root / MODEL_LIST),
            "files_sha256": files_digest,
            "n_files": len(file_sums),
        },
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    # read from the tree again on each access: the writer reads each entry twice
    entries = LazyEntries(len(good), lambda row: _read_model(root, good[row], meshes=meshes))
    store = write_dataset(out_dir / STORE_NAME, entries, attrs=attrs,
                          views=fibonacci_sphere(N_VIEWS), failures=failures, progress=progress)
    counts = {split: sum(published_split(item.split) == split for item in good)
              for split in SPLITS}
    return ImportResult(path=store, n_models=len(good), failures=tuple(failures),
                        split_counts=counts)


def _toolkit_version() -> str:
    import vptoolkit

    return vptoolkit.__version__
