"""Build a viewpoint-quality dataset from a folder of meshes, resumably.

:func:`build_dataset` turns a source tree into one store (see
``dataset_card/SCHEMA.md``). Per model it loads the mesh, cleans it (unless
``clean=False``), samples ``n_points`` surface points with their normals,
computes VE, VR, VKL and VMI over ``n_views`` Fibonacci views and keeps the
result; then it writes ``OUT/dataset.zarr`` or ``OUT/dataset.h5`` with
:func:`vptoolkit.dataset.store.write_dataset`.

Source layout (:func:`discover_models`)
    A ModelNet40-style tree ``<category>/<train|test>/<name>.off`` or any
    folder of meshes: a model's category is the name of its parent folder
    (its grandparent when the parent is ``train`` or ``test``), and files
    directly in the source folder get the source folder's name. Every suffix
    :data:`vptoolkit.io.SUPPORTED_SUFFIXES` names is read; hidden files and
    folders (``.name``) are skipped. A model's name is its file stem and
    must be unique in the dataset: files with the same stem (``a.off`` and
    ``a.obj``, ``a.off`` under ``train/`` and ``test/``, or ``chair/a.off``
    and ``table/a.off``) are all recorded as failures, as nothing tells
    which one is meant.

Splits (:func:`assign_split`)
    80/10/10 from the split seed and ``category/name`` alone, so adding a
    model never moves another; a model under ``test/`` stays test.

Determinism
    The point sample of a model is seeded from the split seed and its
    ``category/name`` (never from a worker or queue position), every
    directory listing is sorted and the cleaning report is stored without
    its timings, so the same source and options give identical arrays,
    records and attributes whatever ``workers`` or ``scheduler`` is.

Staging and resuming
    Each finished model is first written to ``OUT/.staging/`` as one ``.npz``
    file (arrays plus a JSON ``meta`` member as ``uint8``; nothing pickled),
    and each failed one as one ``.failed.json``, both atomically (temporary
    file in the same folder, fsync, :func:`os.replace`). ``build.json``
    there holds the options and the time the build was first started. A
    build killed at any point (even ``kill -9``) is resumed by running the
    same command again: staged models whose source file is unchanged (same
    size and modification time) are kept, left-over temporary files are
    deleted, and the result equals that of an uninterrupted build. The
    staging folder is kept after the store is written, so rerunning (e.g.
    after adding models to the source) computes only what is new; delete
    ``OUT/.staging`` to reclaim its space, after which OUT can no longer be
    resumed.

Parallelism
    ``workers=N`` runs models in N local processes (``forkserver`` or
    ``spawn`` start method, numba limited to one thread per process);
    ``scheduler="tcp://host:port"`` sends them to a running Dask
    ``distributed`` cluster whose workers can read the source folder under
    the same path. In both cases the main process writes the staged files.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import multiprocessing
import os
import re
import secrets
import time
import zipfile
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Literal, overload

import numpy as np
from numpy.typing import NDArray

from vptoolkit.camera import Camera
from vptoolkit.checks import as_path, check_bool, check_int, one_line
from vptoolkit.dataset.manifest import sha256_file
from vptoolkit.dataset.store import ModelEntry, write_dataset
from vptoolkit.errors import InputError, MissingDependencyError, VptoolkitError
from vptoolkit.files import atomic_write
from vptoolkit.io import SUPPORTED_SUFFIXES, find_mesh_files
from vptoolkit.optional import is_available, require
from vptoolkit.sphere import fibonacci_sphere

__all__ = [
    "FORMATS",
    "SPLIT_FRACTIONS",
    "STAGES",
    "STAGING_DIR",
    "BuildResult",
    "SourceModel",
    "assign_split",
    "build_dataset",
    "discover_models",
]

_log = logging.getLogger(__name__)

FORMATS: dict[str, str] = {"zarr": "dataset.zarr", "hdf5": "dataset.h5"}
"""Store file name inside OUT for each ``format``."""

SPLIT_FRACTIONS: dict[str, float] = {"train": 0.8, "val": 0.1, "test": 0.1}
"""Fractions of the train/val/test split (SCHEMA.md)."""

STAGES = ("load", "clean", "sample", "measure", "write")
"""Stages of a model whose seconds :class:`BuildResult` reports."""

STAGING_DIR = ".staging"
"""Folder inside OUT that holds the finished models of a build in progress."""

BACKEND = "raster"
"""Pixel-counting backend of every build (:mod:`vptoolkit.visibility`)."""

VIEW_SET_VIEWS = 6
"""Most views in each model's stored coverage view set (SCHEMA.md, "Model record")."""

_FOLDER_SPLITS = ("train", "test")
_STAGING_VERSION = 1
_BUILD_FILE = "build.json"
_LOCK_FILE = "lock"
_TEMP_SUFFIX = ".partial"  # temporary files of vptoolkit.files.atomic_write
_MODEL_SUFFIX = ".npz"
_FAILURE_SUFFIX = ".failed.json"
_CONNECT_TIMEOUT = "30s"  # to reach a Dask scheduler
# Dask's comm protocols; http:// (a dashboard) and bare words are refused before connecting.
_SCHEDULER_ADDRESS = re.compile(
    r"(?:(?:tcp|tls|ws|wss|ucx)://)?(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):\d{1,5}"
    r"|inproc://\S+"
)
_ARRAY_NAMES = (
    "points",
    "normals",
    "quality",
    "quality_raw",
    "best_index",
    "best_value",
    "worst_index",
    "worst_value",
    "vertices",
    "faces",
)
# Options a resumed build must share with the staged one; anything else would
# mix models computed two ways in one store.
_RESUME_OPTIONS = (
    "format",
    "n_views",
    "resolution",
    "n_points",
    "max_faces",
    "clean",
    "remesh",
    "split_seed",
    "backend",
    "camera",
    "toolkit_version",
)


@dataclass(frozen=True)
class SourceModel:
    """One mesh file found in a source folder.

    Attributes
    ----------
    path : Path
        Absolute path of the file.
    source : str
        Path relative to the source folder, with ``/`` separators.
    category : str
        Category (parent folder name, see :func:`discover_models`).
    name : str
        File stem, the model's name.
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


@dataclass(frozen=True)
class BuildResult:
    """Outcome of :func:`build_dataset`.

    Attributes
    ----------
    path : Path
        The store written (``OUT/dataset.zarr`` or ``OUT/dataset.h5``).
    n_models : int
        Models in the store.
    n_failures : int
        Inputs that could not be processed.
    failures : tuple of dict
        One ``{"source", "category", "reason"}`` per failure, sorted by source.
    seconds : float
        Wall-clock time of this call.
    n_resumed : int
        Models (and failures) taken from the staging folder instead of being
        computed again (default: 0).
    stage_seconds : dict
        Seconds spent per stage of :data:`STAGES` over the models computed in
        this call (``load``, ``clean``, ``measure``, ``sample``: summed over
        the workers' models, so with several workers they add up to more than
        the wall-clock time; ``write``: staging files and the final store, in
        the main process). Never stored: timings differ from run to run.
    n_computed : int
        Models computed (not resumed) in this call, the count behind
        ``stage_seconds`` (default: 0).
    """

    path: Path
    n_models: int
    n_failures: int
    failures: tuple[dict[str, str], ...]
    seconds: float
    n_resumed: int = 0
    stage_seconds: dict[str, float] = field(default_factory=dict)
    n_computed: int = 0


# --------------------------------------------------------------------------- discovery


def discover_models(
    src: str | os.PathLike[str], categories: Iterable[str] | None = None
) -> list[SourceModel]:
    """Find the mesh files under a source folder.

    Parameters
    ----------
    src : str or os.PathLike
        A ModelNet40-style tree (``<category>/<train|test>/<name>.off``) or
        any folder of meshes. A file's category is its parent folder's name,
        or its grandparent's when the parent is ``train`` or ``test``; files
        directly in ``src`` get ``src``'s own name. Files whose suffix is not
        in :data:`~vptoolkit.io.SUPPORTED_SUFFIXES` and hidden files and
        folders (name starting with ``.``) are ignored.
    categories : iterable of str, optional
        Keep only these categories (default: all).

    Returns
    -------
    list of SourceModel
        Sorted by ``(category, name, source)``. Duplicate names are kept
        here; :func:`build_dataset` records them as failures.

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
    models = [_source_model(root, path) for path in find_mesh_files(root)]
    if not models:
        raise InputError(
            f"{root}: no mesh files found (looked for {', '.join(SUPPORTED_SUFFIXES)})"
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
        name=path.stem,
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


def _split_duplicates(
    models: Sequence[SourceModel],
) -> tuple[list[SourceModel], list[dict[str, str]]]:
    """Separate models with a unique name from duplicates, which all become failures.

    A name must be unique within the dataset (SCHEMA.md), so ``chair/a.off``
    and ``table/a.off`` clash as much as ``chair/a.off`` and ``chair/a.obj``.
    """
    by_name: dict[str, list[SourceModel]] = {}
    for model in models:
        by_name.setdefault(model.name, []).append(model)
    unique: list[SourceModel] = []
    failures: list[dict[str, str]] = []
    for model in models:
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


def _unit_hash(text: str) -> float:
    """First 8 bytes of SHA-256(text), big-endian, divided by 2**64: a float in [0, 1)."""
    digest = hashlib.sha256(text.encode("utf-8")).digest()
    return int.from_bytes(digest[:8], "big") / 2**64


def _model_seed(split_seed: int, model_id: str) -> int:
    """Point-sampling seed of one model: from the base seed and its stable id only."""
    digest = hashlib.sha256(f"{split_seed}:points:{model_id}".encode()).digest()
    return int.from_bytes(digest[:8], "big")


# --------------------------------------------------------------------------- the build


def build_dataset(
    src: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    format: Literal["zarr", "hdf5"] = "zarr",
    categories: Iterable[str] | None = None,
    n_views: int = 1000,
    resolution: int = 1024,
    n_points: int = 20000,
    max_faces: int = 10000,
    clean: bool = True,
    remesh: bool = False,
    workers: int = 1,
    scheduler: str | None = None,
    split_seed: int = 0,
    progress: bool = False,
) -> BuildResult:
    """Measure every mesh under ``src`` and write one dataset store in ``out``.

    Parameters
    ----------
    src : str or os.PathLike
        Source folder (see :func:`discover_models`).
    out : str or os.PathLike
        Build folder: new, empty, or one a previous build of the same options
        left (it is resumed). Gets ``dataset.zarr`` or ``dataset.h5`` and the
        ``.staging`` folder.
    format : {"zarr", "hdf5"}
        Store format (default: "zarr").
    categories : iterable of str, optional
        Build only these categories (default: all).
    n_views : int
        Fibonacci views per model (default: 1000).
    resolution : int
        Side of the triangle-ID image in pixels (default: 1024).
    n_points : int
        Surface points per model (default: 20000).
    max_faces : int
        Face budget of the cleaned meshes (default: 10000).
    clean : bool
        Clean each mesh before measuring (default: True).
    remesh : bool
        With ``clean``, also remesh isotropically in the last cleaning step
        (:func:`vptoolkit.clean.clean_mesh`; default: False). Viewpoint
        entropy depends on the tessellation: shapes assembled from a few
        large faces (``vptoolkit.synthetic``) reward views that scanned or
        decimated real meshes do not, and remeshing removes that difference
        (on 16 procedural shapes the PCA view scores 41 % VE against 64 % for
        a random view as assembled, 79 % against 78 % remeshed).
    workers : int
        Local worker processes (default: 1, in this process).
    scheduler : str, optional
        Address of a running Dask distributed scheduler, e.g.
        ``"tcp://127.0.0.1:8786"``; its workers must see ``src`` under the
        same path (default: None, run locally).
    split_seed : int
        Seed of the split and of every model's point sample (default: 0).
    progress : bool
        Show a progress bar (models, failures, ETA) on stderr (default: False).

    Returns
    -------
    BuildResult
        The store's path, counts, failures and seconds.

    Raises
    ------
    InputError
        If an option is invalid, ``src`` has no meshes, ``out`` is a
        non-empty folder that is not a build folder, ``out`` holds a build
        with other options, another build is running in ``out``, or the
        scheduler cannot be reached.
    MissingDependencyError
        If zarr/h5py, pymeshlab (with ``clean``) or distributed (with
        ``scheduler``) is not installed.

    Notes
    -----
    A model that fails with a :class:`~vptoolkit.errors.VptoolkitError`
    (unreadable file, failed cleaning or measurement) or with any other
    exception is recorded as a failure with a one-line reason, and the build
    goes on. A local worker process that dies (e.g. a crash in a native
    library) is retried once alone, then recorded as a failure that is not
    staged, so the next run tries it again.
    """
    started = time.perf_counter()
    options = _check_options(
        format=format,
        n_views=n_views,
        resolution=resolution,
        n_points=n_points,
        max_faces=max_faces,
        clean=clean,
        remesh=remesh,
        split_seed=split_seed,
    )
    workers = check_int(workers, "workers", minimum=1)
    if scheduler is not None and (not isinstance(scheduler, str) or not scheduler.strip()):
        raise InputError(
            f"scheduler: expected an address such as tcp://host:8786, got {scheduler!r}"
        )
    if scheduler is not None and not _SCHEDULER_ADDRESS.fullmatch(scheduler.strip()):
        raise InputError(
            f"scheduler: {scheduler!r} is not a Dask scheduler address; expected "
            "tcp://host:port (or tls://, ws://, wss://, ucx://, inproc://)"
        )
    if scheduler is not None and workers != 1:
        raise InputError("workers: give either workers > 1 or scheduler, not both")
    progress = check_bool(progress, "progress")
    out_dir = as_path(out, "out")
    _check_dependencies(options, scheduler)

    models = discover_models(src, categories)
    root = as_path(src, "src").resolve()
    models = _outside(models, out_dir)
    unique, duplicate_failures = _split_duplicates(models)

    staging = _prepare_out(out_dir)
    with _build_lock(staging):
        created = _resume_or_start(staging, options, root)
        done, staged_failures, todo = _scan_staging(staging, unique)
        _warn_about_models_left_out(staging, unique, out_dir)
        n_resumed = len(done) + len(staged_failures)
        run_failures: dict[str, dict[str, str]] = {}
        stage_seconds = dict.fromkeys((*STAGES, "models"), 0.0)
        tasks = [_task(model, options) for model in todo]
        with _progress_bar(
            len(unique) + len(duplicate_failures),
            n_resumed + len(duplicate_failures),
            len(staged_failures) + len(duplicate_failures),
            progress,
        ) as bar:

            def finished(result: Mapping[str, Any]) -> None:
                model_id = result["model_id"]
                if result["status"] == "ok":
                    started_write = time.perf_counter()
                    done[model_id] = _stage_model(staging, result)
                    for stage, spent in result.get("seconds", {}).items():
                        stage_seconds[stage] += spent
                    stage_seconds["write"] += time.perf_counter() - started_write
                    stage_seconds["models"] += 1
                else:
                    if result["staged"]:
                        _stage_failure(staging, result)
                        staged_failures[model_id] = result["failure"]
                    else:
                        run_failures[model_id] = result["failure"]
                    _log.info("failed: %s", result["failure"]["reason"])
                bar.advance(is_failure=result["status"] != "ok")

            if scheduler is not None:
                _run_on_cluster(tasks, scheduler, finished)
            else:
                _run_locally(tasks, workers, finished)

        entries = _StagedEntries(
            [
                (done[model.model_id], _split_of(model, options["split_seed"]))
                for model in unique
                if model.model_id in done
            ]
        )
        failures = sorted(
            [*duplicate_failures, *staged_failures.values(), *run_failures.values()],
            key=lambda failure: (failure["source"], failure["reason"]),
        )
        store_path = out_dir / FORMATS[options["format"]]
        started_store = time.perf_counter()
        write_dataset(
            store_path,
            entries,
            attrs=_store_attrs(options, source=root.name, created=created),
            views=fibonacci_sphere(options["n_views"]),
            failures=failures,
            progress=progress,
        )
        store_seconds = time.perf_counter() - started_store
    n_computed = int(stage_seconds.pop("models"))
    stage_seconds["write"] += store_seconds
    return BuildResult(
        path=store_path,
        n_models=len(entries),
        n_failures=len(failures),
        failures=tuple(failures),
        seconds=time.perf_counter() - started,
        n_resumed=n_resumed,
        stage_seconds=stage_seconds,
        n_computed=n_computed,
    )


def _check_options(
    *,
    format: str,
    n_views: int,
    resolution: int,
    n_points: int,
    max_faces: int,
    clean: bool,
    remesh: bool,
    split_seed: int,
) -> dict[str, Any]:
    """Validate the options that define the result; return them as JSON types."""
    if format not in FORMATS:
        raise InputError(f"format: expected one of {', '.join(FORMATS)}, got {format!r}")
    import vptoolkit

    return {
        "format": format,
        "n_views": check_int(n_views, "n_views", minimum=1),
        "resolution": check_int(resolution, "resolution", minimum=1, maximum=16384),
        "n_points": check_int(n_points, "n_points", minimum=1),
        "max_faces": check_int(max_faces, "max_faces", minimum=4),
        "clean": check_bool(clean, "clean"),
        "remesh": check_bool(remesh, "remesh"),
        "split_seed": check_int(split_seed, "split_seed", minimum=None),
        "backend": BACKEND,
        "camera": Camera().to_dict(),
        "toolkit_version": vptoolkit.__version__,
    }


def _check_dependencies(options: Mapping[str, Any], scheduler: str | None) -> None:
    """Fail before any work when a needed package is missing, instead of failing every model."""
    # h5py is a core dependency (plain `pip install vptoolkit`); zarr comes with [dataset].
    needed: list[tuple[str, str | None]] = [
        ("zarr", "dataset") if options["format"] == "zarr" else ("h5py", None)
    ]
    if options["clean"]:
        needed.append(("pymeshlab", "clean"))
    if scheduler is not None:
        needed.append(("distributed", "cluster"))
    for module, extra in needed:
        if not is_available(module):
            require(module, extra=extra)  # raises MissingDependencyError with the pip command


def _store_attrs(options: Mapping[str, Any], *, source: str, created: str) -> dict[str, Any]:
    return {
        "resolution": options["resolution"],
        "backend": options["backend"],
        "camera": options["camera"],
        "cleaning": {"enabled": options["clean"], "max_faces": options["max_faces"],
                     "remesh": options["remesh"]},
        "split_seed": options["split_seed"],
        "split_fractions": dict(SPLIT_FRACTIONS),
        "source": source,
        "toolkit_version": options["toolkit_version"],
        "created": created,
    }


def _split_of(model: SourceModel, seed: int) -> str:
    return assign_split(model.category, model.name, seed=seed, folder_split=model.folder_split)


def _outside(models: list[SourceModel], out_dir: Path) -> list[SourceModel]:
    """Drop files inside the build folder, in case it lies within the source folder."""
    out_resolved = out_dir.resolve()
    return [model for model in models if not model.path.is_relative_to(out_resolved)]


# --------------------------------------------------------------------------- the build folder


def _prepare_out(out_dir: Path) -> Path:
    """Create OUT and its staging folder, or check that an existing OUT is ours."""
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"{out_dir}: output exists and is not a folder")
    staging = out_dir / STAGING_DIR
    if out_dir.is_dir() and not staging.is_dir() and any(out_dir.iterdir()):
        raise InputError(
            f"{out_dir}: folder is not empty and is not a vptoolkit build folder "
            f"(no {STAGING_DIR}/); choose a new or empty folder"
        )
    staging.mkdir(parents=True, exist_ok=True)
    return staging


@contextlib.contextmanager
def _build_lock(staging: Path) -> Iterator[None]:
    """Hold an exclusive lock on the staging folder (released by the OS if we are killed)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no protection against two builds
        yield
        return
    with open(staging / _LOCK_FILE, "a+b") as handle:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as err:
            raise InputError(
                f"{staging.parent}: another build is running in this folder"
            ) from err
        try:
            yield
        finally:
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)


def _resume_or_start(staging: Path, options: Mapping[str, Any], root: Path) -> str:
    """Check the staged options against ``options`` or record them; return the creation time."""
    build_file = staging / _BUILD_FILE
    if build_file.exists():
        try:
            recorded = json.loads(build_file.read_text(encoding="utf-8"))
            # builds from before the option did not remesh
            staged_options = {"remesh": False, **recorded["options"]}
            created = str(recorded["created"])
        except (ValueError, KeyError, TypeError) as err:
            raise InputError(f"{build_file}: unreadable build record ({err})") from err
        changed = [
            f"{key}={staged_options.get(key)!r} (now {options[key]!r})"
            for key in _RESUME_OPTIONS
            if staged_options.get(key) != options[key]
        ]
        if changed:
            raise InputError(
                f"{staging.parent}: holds a build made with {'; '.join(changed)}; "
                "use a new OUT folder or the same options"
            )
        return created
    created = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    record = {
        "staging_version": _STAGING_VERSION,
        "created": created,
        "source": str(root),
        "options": dict(options),
    }
    _write_atomic(build_file, json.dumps(record, indent=2, sort_keys=True).encode("utf-8"))
    return created


def _stage_key(model_id: str) -> str:
    """File stem of a model in the staging folder: readable, safe and unique."""
    readable = re.sub(r"[^A-Za-z0-9_.-]+", "_", model_id.replace("/", "__"))[:80]
    digest = hashlib.sha256(model_id.encode("utf-8")).hexdigest()[:16]
    return f"m-{readable}-{digest}"


def _scan_staging(
    staging: Path, models: Sequence[SourceModel]
) -> tuple[dict[str, Path], dict[str, dict[str, str]], list[SourceModel]]:
    """Sort models into staged results, staged failures and work still to do.

    Temporary files of an interrupted write are deleted. A staged result is
    kept only when its model id and source file (path, size, modification
    time) still match; otherwise it is deleted and the model is redone.
    """
    names = sorted(os.listdir(staging))
    for name in names:
        if name.endswith(_TEMP_SUFFIX):
            (staging / name).unlink(missing_ok=True)
    present = set(names)
    done: dict[str, Path] = {}
    failed: dict[str, dict[str, str]] = {}
    todo: list[SourceModel] = []
    for model in models:
        key = _stage_key(model.model_id)
        model_file = staging / f"{key}{_MODEL_SUFFIX}"
        failure_file = staging / f"{key}{_FAILURE_SUFFIX}"
        has_model = model_file.name in present
        has_failure = failure_file.name in present
        signature = _signature(model)
        if has_model and not has_failure and _staged_meta_matches(model_file, signature):
            done[model.model_id] = model_file
            continue
        if has_failure and not has_model:
            record = _read_failure(failure_file)
            if record is not None and record.get("signature") == signature:
                failed[model.model_id] = record["failure"]
                continue
        model_file.unlink(missing_ok=True)
        failure_file.unlink(missing_ok=True)
        todo.append(model)
    return done, failed, todo


def _warn_about_models_left_out(
    staging: Path, models: Sequence[SourceModel], out_dir: Path
) -> None:
    """Say so when this run's store will hold fewer models than the folder has staged.

    A rerun with other ``categories`` (or with models removed from the source)
    writes a store of this run's models only; the other staged models are
    kept, and a later run that includes them again takes them from there.
    """
    wanted = {f"{_stage_key(model.model_id)}{_MODEL_SUFFIX}" for model in models}
    others = [
        name for name in sorted(os.listdir(staging))
        if name.startswith("m-") and name.endswith(_MODEL_SUFFIX) and name not in wanted
    ]
    if others:
        _log.warning(
            "%s: %d staged models are not part of this run (other --categories or removed "
            "sources); the store will hold only this run's %d models (the staged ones are "
            "kept for a later run)", out_dir, len(others), len(models),
        )


def _signature(model: SourceModel) -> dict[str, Any]:
    """What identifies the staged result of a source file: id, path, size and mtime."""
    try:
        info = model.path.stat()
        size, mtime_ns = int(info.st_size), int(info.st_mtime_ns)
    except OSError:
        size, mtime_ns = -1, -1
    return {"model_id": model.model_id, "source": model.source, "size": size, "mtime_ns": mtime_ns}


def _staged_meta_matches(path: Path, signature: Mapping[str, Any]) -> bool:
    """Whether a staged model is whole and was made from the same source file.

    Every member is read in full, so a bad CRC or a truncated member anywhere
    in the file (not just in ``meta``) counts as unreadable: the model is
    computed again after one warning, instead of failing the final write.
    """
    try:
        # np.load leaks its file handle when the zip is broken, so open the file here.
        with open(path, "rb") as stream, np.load(stream, allow_pickle=False) as staged:
            meta = _decode_json(staged["meta"])
            missing = [name for name in _ARRAY_NAMES if name not in staged.files]
            if missing:
                raise KeyError(f"no member {missing[0]!r}")
            for name in _ARRAY_NAMES:
                staged[name]  # reads the member in full and checks its CRC
    # unreadable: redo it
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, UnicodeDecodeError) as err:
        _log.warning("%s: staged model unreadable (%s); computing it again", path.name,
                     one_line(err))
        return False
    return bool(meta.get("signature") == signature)


def _read_failure(path: Path) -> dict[str, Any] | None:
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and "failure" in record else None


def _stage_model(staging: Path, result: Mapping[str, Any]) -> Path:
    """Write a finished model's arrays and meta to the staging folder atomically."""
    key = _stage_key(result["model_id"])
    path = staging / f"{key}{_MODEL_SUFFIX}"
    _write_atomic(path, {**result["arrays"], "meta": _encode_json(result["meta"])})
    (staging / f"{key}{_FAILURE_SUFFIX}").unlink(missing_ok=True)
    return path


def _stage_failure(staging: Path, result: Mapping[str, Any]) -> None:
    """Write a failed model's reason and source signature to the staging folder atomically."""
    key = _stage_key(result["model_id"])
    record = {"signature": result["meta"]["signature"], "failure": result["failure"]}
    _write_atomic(
        staging / f"{key}{_FAILURE_SUFFIX}", json.dumps(record, sort_keys=True).encode("utf-8")
    )
    (staging / f"{key}{_MODEL_SUFFIX}").unlink(missing_ok=True)


def _write_atomic(path: Path, payload: bytes | Mapping[str, NDArray[Any]]) -> None:
    """Write bytes, or arrays as a compressed ``.npz``, to ``path`` atomically.

    :func:`vptoolkit.files.atomic_write`: a reader (or a resumed build) sees
    the old file or the whole new one, never a part.
    """
    with atomic_write(path) as stream:
        if isinstance(payload, bytes):
            stream.write(payload)
        else:
            np.savez_compressed(stream, **payload)
    _fsync_folder(path.parent)


def _fsync_folder(folder: Path) -> None:
    """Make a rename durable; a no-op where folders cannot be opened (Windows)."""
    try:
        handle = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover - Windows
        return
    try:
        os.fsync(handle)
    except OSError:  # pragma: no cover - some file systems refuse fsync on folders
        pass
    finally:
        os.close(handle)


def _encode_json(value: Any) -> NDArray[np.uint8]:
    text = json.dumps(value, sort_keys=True, separators=(",", ":"))
    return np.frombuffer(text.encode("utf-8"), dtype=np.uint8).copy()


def _decode_json(array: NDArray[np.uint8]) -> Any:
    return json.loads(np.asarray(array, dtype=np.uint8).tobytes().decode("utf-8"))


class _StagedEntries(Sequence[ModelEntry]):
    """The staged models as a lazy sequence of :class:`ModelEntry`, one file read per item."""

    def __init__(self, items: Sequence[tuple[Path, str]]) -> None:
        self._items = list(items)

    def __len__(self) -> int:
        return len(self._items)

    @overload
    def __getitem__(self, index: int) -> ModelEntry: ...

    @overload
    def __getitem__(self, index: slice) -> _StagedEntries: ...

    def __getitem__(self, index: int | slice) -> ModelEntry | _StagedEntries:
        if isinstance(index, slice):
            return _StagedEntries(self._items[index])
        path, split = self._items[index]
        with open(path, "rb") as stream, np.load(stream, allow_pickle=False) as staged:
            arrays = {name: staged[name] for name in _ARRAY_NAMES}
            meta = _decode_json(staged["meta"])
        record = meta["record"]
        return ModelEntry(
            name=record["name"],
            category=record["category"],
            split=split,
            source=record["source"],
            source_sha256=record["source_sha256"],
            cleaning=record["cleaning"],
            view_set=record.get("view_set"),
            **arrays,
        )


# --------------------------------------------------------------------------- progress


class _Progress:
    """A tqdm bar over models with the failure count, or nothing."""

    def __init__(self, bar: Any, n_failures: int) -> None:
        self._bar = bar
        self._n_failures = n_failures
        if bar is not None:
            bar.set_postfix(failed=n_failures)

    def advance(self, *, is_failure: bool) -> None:
        if is_failure:
            self._n_failures += 1
        if self._bar is not None:
            if is_failure:
                self._bar.set_postfix(failed=self._n_failures, refresh=False)
            self._bar.update(1)


@contextlib.contextmanager
def _progress_bar(total: int, initial: int, n_failures: int, enabled: bool) -> Iterator[_Progress]:
    if not enabled:
        yield _Progress(None, n_failures)
        return
    import sys

    from tqdm import tqdm

    with tqdm(total=total, initial=initial, desc="models", unit="model", file=sys.stderr) as bar:
        yield _Progress(bar, n_failures)


# --------------------------------------------------------------------------- running the tasks


def _task(model: SourceModel, options: Mapping[str, Any]) -> dict[str, Any]:
    """The plain, picklable arguments of one model's work."""
    return {
        "path": str(model.path),
        "source": model.source,
        "category": model.category,
        "name": model.name,
        "n_views": options["n_views"],
        "resolution": options["resolution"],
        "n_points": options["n_points"],
        "max_faces": options["max_faces"],
        "clean": options["clean"],
        "remesh": options["remesh"],
        "seed": _model_seed(options["split_seed"], model.model_id),
        "signature": _signature(model),
        "numba_threads": None,
    }


def _run_locally(
    tasks: Sequence[dict[str, Any]],
    workers: int,
    finished: Callable[[Mapping[str, Any]], None],
    *,
    function: Callable[[Mapping[str, Any]], dict[str, Any]] | None = None,
) -> None:
    """Run the tasks in this process (``workers == 1``) or in a pool of processes.

    ``function`` (default: :func:`_process_model`) must be a top-level
    function. If a worker process dies, the pool breaks and takes the tasks
    in flight (at most ``2 * workers``) with it: each of them is then run
    alone in a fresh process, and a task that kills that one too becomes a
    failure that is not staged.
    """
    function = function or _process_model
    if workers == 1 or len(tasks) <= 1:
        for task in tasks:
            finished(function(task))
        return
    context = multiprocessing.get_context(
        "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    )
    pending = deque({**task, "numba_threads": 1} for task in tasks)
    window = 2 * workers
    while pending:
        crashed: list[dict[str, Any]] = []
        with ProcessPoolExecutor(max_workers=workers, mp_context=context,
                                 initializer=_die_with_parent, initargs=(os.getpid(),)) as pool:
            running: dict[Future[dict[str, Any]], dict[str, Any]] = {}
            while (pending or running) and not crashed:
                while pending and len(running) < window:
                    task = pending.popleft()
                    running[pool.submit(function, task)] = task
                completed, _ = wait(running, return_when=FIRST_COMPLETED)
                for future in completed:
                    task = running.pop(future)
                    try:
                        result = future.result()
                    except BrokenProcessPool:
                        crashed.append(task)
                    else:
                        finished(result)
            crashed.extend(running.values())
        for task in sorted(crashed, key=lambda task: task["source"]):
            finished(_run_alone(task, context, function))


def _run_alone(
    task: Mapping[str, Any],
    context: Any,
    function: Callable[[Mapping[str, Any]], dict[str, Any]],
) -> dict[str, Any]:
    """Retry a task whose pool broke in a process of its own; a second crash is a failure."""
    with ProcessPoolExecutor(max_workers=1, mp_context=context,
                             initializer=_die_with_parent, initargs=(os.getpid(),)) as pool:
        try:
            return pool.submit(function, task).result()
        except BrokenProcessPool:
            return _failure_result(
                task,
                f"{task['source']}: the worker process died while processing it",
                staged=False,
            )


_PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>
_WATCHDOG_SECONDS = 1.0


def _die_with_parent(build_pid: int) -> None:
    """Initializer of every worker process: end it when the build process ends.

    A worker started by the ``forkserver`` is the server's child, not the
    build's, so a build killed with ``kill -9`` would leave its workers (each
    holding a mesh and numba's buffers) running forever. On Linux the kernel
    sends SIGKILL to the worker when its parent dies (``PR_SET_PDEATHSIG``,
    through ctypes); everywhere, a daemon thread checks every second that the
    build process is alive and exits the worker if not.
    """
    import signal
    import sys
    import threading

    if sys.platform.startswith("linux"):
        import ctypes

        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)

    def watch() -> None:
        while True:
            time.sleep(_WATCHDOG_SECONDS)
            try:
                os.kill(build_pid, 0)
            except ProcessLookupError:
                os._exit(1)
            except PermissionError:  # pragma: no cover - pid reused by another user
                os._exit(1)

    threading.Thread(target=watch, name="vptoolkit-build-watchdog", daemon=True).start()


def _run_on_cluster(
    tasks: Sequence[dict[str, Any]], address: str, finished: Callable[[Mapping[str, Any]], None]
) -> None:
    """Send the tasks to a Dask distributed scheduler and stage results as they arrive."""
    distributed = require("distributed", extra="cluster")
    try:
        client = distributed.Client(address, set_as_default=False, timeout=_CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as err:
        raise InputError(f"scheduler: cannot connect to {address} ({err})") from err
    try:
        futures = {
            client.submit(
                _process_model,
                {**task, "numba_threads": 1},
                key=f"vptoolkit-build-{_stage_key(task['category'] + '/' + task['name'])}-"
                f"{secrets.token_hex(4)}",
                pure=False,
            ): task
            for task in tasks
        }
        for future in distributed.as_completed(list(futures), loop=client.loop):
            task = futures.pop(future)
            try:
                result = future.result()
            # A lost worker or a cancelled task is the cluster's failure, not the
            # model's: record it for this run without staging it, so a rerun retries.
            except Exception as err:  # noqa: BLE001
                result = _failure_result(
                    task,
                    f"{task['source']}: cluster task failed "
                    f"({type(err).__name__}: {one_line(err)})",
                    staged=False,
                )
            future.release()
            finished(result)
    finally:
        client.close()


# --------------------------------------------------------------------------- one model


def _process_model(task: Mapping[str, Any]) -> dict[str, Any]:
    """Load, clean, sample and measure one model; never raises.

    A top-level function of plain arguments, so local process pools and Dask
    workers can run it. The caller writes the staged file.

    Parameters
    ----------
    task : dict
        ``path``, ``source``, ``category``, ``name``, ``n_views``,
        ``resolution``, ``n_points``, ``max_faces``, ``clean``, ``seed``,
        ``signature`` and ``numba_threads`` (None leaves numba alone).

    Returns
    -------
    dict
        ``model_id``, ``status`` (``"ok"`` or ``"failed"``), ``meta``, and
        ``arrays`` (the ModelEntry arrays in schema dtypes) or ``failure``
        (``{"source", "category", "reason"}``) and ``staged``.
    """
    if task.get("numba_threads"):
        import numba

        numba.set_num_threads(int(task["numba_threads"]))
    try:
        return _measure_model(task)
    # The worker's environment or load, not the model: recorded but not staged, so
    # the next run tries the model again.
    except MissingDependencyError as err:
        return _failure_result(task, f"{task['source']}: {one_line(err)}", staged=False)
    except MemoryError:
        return _failure_result(task, f"{task['source']}: out of memory", staged=False)
    except VptoolkitError as err:
        return _failure_result(task, _with_source(task["source"], one_line(err)))
    # This is the one place a broad except is right: an unexpected bug on one
    # model of thousands must not stop the batch; it is recorded with its type.
    except Exception as err:  # noqa: BLE001
        return _failure_result(
            task, f"{task['source']}: unexpected {type(err).__name__}: {one_line(err)}"
        )


def _measure_model(task: Mapping[str, Any]) -> dict[str, Any]:
    from vptoolkit.clean import clean_mesh
    from vptoolkit.io import load_mesh
    from vptoolkit.points import sample_surface
    from vptoolkit.view_sets import measure_view_set

    path = Path(task["path"])
    seconds: dict[str, float] = {}
    started = time.perf_counter()
    source_sha256 = sha256_file(path)
    mesh = load_mesh(path)
    seconds["load"] = time.perf_counter() - started
    cleaning = None
    started = time.perf_counter()
    if task["clean"]:
        mesh, report = clean_mesh(mesh, max_faces=task["max_faces"], remesh=task["remesh"])
        cleaning = _without_timings(report.to_dict())
    seconds["clean"] = time.perf_counter() - started
    started = time.perf_counter()
    quality, view_set = measure_view_set(mesh, VIEW_SET_VIEWS, n_views=task["n_views"],
                                         resolution=task["resolution"], backend=BACKEND)
    seconds["measure"] = time.perf_counter() - started
    started = time.perf_counter()
    sample = sample_surface(mesh, task["n_points"], seed=task["seed"])
    seconds["sample"] = time.perf_counter() - started
    columns = np.arange(quality.raw.shape[1])
    raw = quality.raw.astype(np.float32)
    arrays = {
        "points": sample.points.astype(np.float32),
        "normals": sample.normals.astype(np.float32),
        "quality": quality.normalized.astype(np.float32),
        "quality_raw": raw,
        "best_index": quality.best_index.astype(np.int64),
        "best_value": raw[quality.best_index, columns],
        "worst_index": quality.worst_index.astype(np.int64),
        "worst_value": raw[quality.worst_index, columns],
        "vertices": mesh.vertices.astype(np.float32),
        "faces": mesh.faces.astype(np.int32),
    }
    record = {
        "name": task["name"],
        "category": task["category"],
        "source": task["source"],
        "source_sha256": source_sha256,
        "n_vertices": mesh.n_vertices,
        "n_faces": mesh.n_faces,
        "cleaning": cleaning,
        "view_set": view_set.record(),
    }
    return {
        "model_id": f"{task['category']}/{task['name']}",
        "status": "ok",
        "meta": {"signature": task["signature"], "record": record},
        "arrays": arrays,
        "seconds": seconds,  # wall-clock per stage: reported, never stored
    }


def _failure_result(task: Mapping[str, Any], reason: str, *, staged: bool = True) -> dict[str, Any]:
    return {
        "model_id": f"{task['category']}/{task['name']}",
        "status": "failed",
        "meta": {"signature": task["signature"]},
        "failure": {"source": task["source"], "category": task["category"], "reason": reason},
        "staged": staged,
    }


def _failure(model: SourceModel, reason: str) -> dict[str, str]:
    return {"source": model.source, "category": model.category, "reason": reason}


def _with_source(source: str, reason: str) -> str:
    """Keep a reason that starts with the file or model name; prefix the source path otherwise."""
    path = Path(source)
    if reason.startswith((f"{path.name}:", f"{path.stem}:", f"{source}:")):
        return reason
    return f"{source}: {reason}"


def _without_timings(report: Mapping[str, Any]) -> dict[str, Any]:
    """The cleaning report without its wall-clock ``seconds``, which differ from run to run."""
    cleaned = {key: value for key, value in report.items() if key != "seconds"}
    if isinstance(cleaned.get("steps"), list):
        cleaned["steps"] = [
            {key: value for key, value in step.items() if key != "seconds"}
            for step in cleaned["steps"]
        ]
    return cleaned


# --------------------------------------------------------------------------- small checks
