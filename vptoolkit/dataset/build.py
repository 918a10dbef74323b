"""Build a viewpoint-quality dataset from a folder of meshes, resumably.

:func:`build_dataset` turns a source tree into one store (see
``vptoolkit/dataset_card/SCHEMA.md``). Per model it loads the mesh, cleans it (unless
``clean=False``), samples ``n_points`` surface points with their normals,
computes VE, VR, VKL and VMI over ``n_views`` Fibonacci views and keeps the
result; then it writes ``OUT/dataset.zarr`` or ``OUT/dataset.h5`` with
:func:`vptoolkit.dataset.writer.write_dataset`. This module is the
orchestration; its parts live beside it:

- :mod:`vptoolkit.dataset.sources`: finding the mesh files, model ids,
  categories, duplicate names, splits and per-model seeds;
- :mod:`vptoolkit.dataset.split_files`: a published split read from a file
  (``splits``) instead of the seeded one;
- :mod:`vptoolkit.dataset.staging`: the resumable ``OUT/.staging`` folder,
  its files and their validation (how a killed build resumes);
- :mod:`vptoolkit.dataset.compute`: what one model's task does (load,
  clean, measure, sample) and the seconds of each stage;
- :mod:`vptoolkit.parallel`: the process pool and the Dask runner.

Determinism
    The point sample of a model is seeded from the split seed and its
    ``category/name`` (never from a worker or queue position), every
    directory listing is sorted and the cleaning report is stored without
    its timings, so the same source and options give identical arrays,
    records and attributes whatever ``workers`` or ``scheduler`` is.

Parallelism
    ``workers=N`` runs models in N local processes (``forkserver`` or
    ``spawn`` start method, numba limited to one thread per process);
    ``scheduler="tcp://host:port"`` sends them to a running Dask
    ``distributed`` cluster whose workers can read the source folder under
    the same path. In both cases the main process writes the staged files.
"""

from __future__ import annotations

import hashlib
import logging
import os
import sys
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from vptoolkit.camera import Camera
from vptoolkit.checks import as_path, check_bool, check_int
from vptoolkit.clean.simplify import MAX_FACES
from vptoolkit.conventions import N_VIEWS, RESOLUTION, SEED
from vptoolkit.dataset.compute import (
    BACKEND,
    FailedModel,
    ModelTask,
    cluster_lost,
    process_model,
    worker_died,
)
from vptoolkit.dataset.schema import published_split
from vptoolkit.dataset.sources import (
    SPLIT_FRACTIONS,
    SourceModel,
    discover_models,
    model_seed,
    models_outside,
    split_duplicates,
    split_of,
    spread_over_categories,
)
from vptoolkit.dataset.split_files import read_split_file
from vptoolkit.dataset.staging import (
    StagedEntries,
    build_lock,
    prepare_out,
    resume_or_start,
    scan_staging,
    source_signature,
    stage_failure,
    stage_key,
    stage_model,
    warn_about_models_left_out,
)
from vptoolkit.dataset.writer import write_dataset
from vptoolkit.errors import InputError
from vptoolkit.optional import is_available, require
from vptoolkit.parallel import check_scheduler_address, run_on_cluster, run_tasks
from vptoolkit.points import N_SURFACE_POINTS
from vptoolkit.progress import progress_bar
from vptoolkit.sphere import fibonacci_sphere

__all__ = [
    "COMPILE_NOTICE",
    "FORMATS",
    "STAGES",
    "BuildResult",
    "SplitFileReport",
    "build_dataset",
]

_log = logging.getLogger(__name__)

FORMATS: dict[str, str] = {"zarr": "dataset.zarr", "hdf5": "dataset.h5"}
"""Store file name inside OUT for each ``format``."""

STAGES = ("load", "clean", "sample", "measure", "write")
"""Stages of a model whose seconds :class:`BuildResult` reports."""


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
    split_file : SplitFileReport or None
        With ``splits``: how many models the file placed and which of its
        names are not models of the source (default: None).
    """

    path: Path
    n_models: int
    n_failures: int
    failures: tuple[dict[str, str], ...]
    seconds: float
    n_resumed: int = 0
    stage_seconds: dict[str, float] = field(default_factory=dict)
    n_computed: int = 0
    split_file: SplitFileReport | None = None


@dataclass(frozen=True)
class SplitFileReport:
    """How a split file of :func:`build_dataset` (``splits``) matched the source.

    Attributes
    ----------
    path : Path
        The split file.
    n_placed : int
        Models of the source (after ``categories``) the file gave a split.
    not_in_source : tuple of str
        Names in the file that are not models of the source, sorted.
    """

    path: Path
    n_placed: int
    not_in_source: tuple[str, ...] = ()


def build_dataset(
    src: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    format: Literal["zarr", "hdf5"] = "zarr",
    categories: Iterable[str] | None = None,
    n_views: int = N_VIEWS,
    resolution: int = RESOLUTION,
    n_points: int = N_SURFACE_POINTS,
    max_faces: int = MAX_FACES,
    clean: bool = True,
    remesh: bool = False,
    workers: int = 1,
    scheduler: str | None = None,
    split_seed: int = SEED,
    splits: str | os.PathLike[str] | None = None,
    max_models: int | None = None,
    progress: bool = False,
    compile_notice: bool | None = None,
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
        Also remesh isotropically in the last cleaning step (needs ``clean``)
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
    splits : str or os.PathLike, optional
        A published split to use instead of the seeded one
        (:func:`~vptoolkit.dataset.split_files.read_split_file`): a
        ``name,split`` CSV, or the paper authors' ``small.txt`` with their
        rule over the lines of ``categories``. Every model of the source must
        be in it; names in it that the source lacks are reported in
        :attr:`BuildResult.split_file` (default: None, the seeded split).
    max_models : int, optional
        Build only this many models, taken in turn from each category
        (:func:`~vptoolkit.dataset.sources.spread_over_categories`); their
        splits are those of the whole source, and models with duplicate names
        are left out instead of recorded as failures. A build folder is
        resumed only with the same value (default: None, every model).
    progress : bool
        Show a progress bar (models, failures, ETA) on stderr (default: False).
    compile_notice : bool, optional
        Print :data:`COMPILE_NOTICE` on stderr before the first model when
        numba has no usable cache of the rasteriser here, so the wait is
        explained; never with ``scheduler``, whose workers have their own
        caches (default: None, as ``progress``).

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
        scheduler cannot be reached, or the split file cannot be read or
        does not place every model of the source (the message counts and
        names them).
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
        splits=splits,
        max_models=max_models,
    )
    workers = check_int(workers, "workers", minimum=1)
    if scheduler is not None:
        scheduler = check_scheduler_address(scheduler)
    if scheduler is not None and workers != 1:
        raise InputError("workers: give either workers > 1 or scheduler, not both")
    progress = check_bool(progress, "progress")
    compile_notice = progress if compile_notice is None else check_bool(compile_notice,
                                                                        "compile_notice")
    out_dir = as_path(out, "out")
    try:
        out_dir.resolve()
    except (RuntimeError, OSError) as err:  # RuntimeError up to Python 3.12, ELOOP after
        raise InputError(f"out: {out_dir}: symbolic link loop; give a folder that can be "
                         "created") from err
    _check_dependencies(options, scheduler)

    selection = select_models(src, out_dir, categories=categories, splits=splits,
                              max_models=options["max_models"],
                              split_seed=options["split_seed"])
    root, unique, duplicate_failures = selection.root, selection.models, selection.duplicates
    split_report = selection.split_file

    staging = prepare_out(out_dir)
    with build_lock(staging):
        created = resume_or_start(staging, options, root)
        done, staged_failures, todo = scan_staging(staging, unique)
        warn_about_models_left_out(staging, unique, out_dir)
        n_resumed = len(done) + len(staged_failures)
        run_failures: dict[str, dict[str, str]] = {}
        stage_seconds = dict.fromkeys((*STAGES, "models"), 0.0)
        if compile_notice and todo and scheduler is None:  # a cluster's caches are not ours
            _say_if_compiling()
        tasks = (_task(model, options) for model in todo)
        results = (
            run_on_cluster(process_model, tasks, address=scheduler, failed=cluster_lost,
                           name=lambda task: f"vptoolkit-build-{stage_key(task.model_id)}")
            if scheduler is not None
            else run_tasks(process_model, tasks, workers=workers, crashed=worker_died)
        )
        with progress_bar(
            total=len(unique) + len(duplicate_failures),
            description="models",
            unit="model",
            enabled=progress,
            initial=n_resumed + len(duplicate_failures),
        ) as bar:
            n_failed = len(staged_failures) + len(duplicate_failures)
            bar.set_postfix(failed=n_failed)
            for result in results:
                if isinstance(result, FailedModel):
                    if result.is_staged:
                        stage_failure(staging, result)
                        staged_failures[result.model_id] = result.failure
                    else:
                        run_failures[result.model_id] = result.failure
                    _log.info("failed: %s", result.failure["reason"])
                    n_failed += 1
                    bar.set_postfix(failed=n_failed, refresh=False)
                else:
                    started_write = time.perf_counter()
                    done[result.model_id] = stage_model(staging, result)
                    for stage, spent in result.seconds.items():
                        stage_seconds[stage] += spent
                    stage_seconds["write"] += time.perf_counter() - started_write
                    stage_seconds["models"] += 1
                bar.update(1)

        entries = StagedEntries(
            [
                (done[model.model_id], selection.splits[model.model_id])
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
            attrs=_store_attrs(options, source=root.name, created=created,
                               split_file=split_report),
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
        split_file=split_report,
    )


@dataclass(frozen=True)
class ModelSelection:
    """The models a build takes from its source (:func:`select_models`).

    Attributes
    ----------
    root : Path
        The source folder, resolved.
    models : list of SourceModel
        The models to build, in discovery order (after ``categories``,
        duplicates and ``max_models``).
    duplicates : list of dict
        Failure records of the files with a duplicate name (empty with
        ``max_models``, which leaves them out).
    splits : dict
        ``train``, ``val`` or ``test`` of each model id of ``models``.
    split_file : SplitFileReport or None
        How the split file matched the source, with ``splits``.
    n_found : int
        Models of the source after ``categories``, before ``max_models``.
    """

    root: Path
    models: list[SourceModel]
    duplicates: list[dict[str, str]]
    splits: dict[str, str]
    split_file: SplitFileReport | None
    n_found: int


def select_models(
    src: str | os.PathLike[str], out_dir: Path, *, categories: Iterable[str] | None,
    splits: str | os.PathLike[str] | None, max_models: int | None, split_seed: int,
) -> ModelSelection:
    """Discover the models of ``src`` and choose those a build with these options takes."""
    models = discover_models(src, categories)
    root = as_path(src, "src").resolve()
    models = models_outside(models, out_dir)
    unique, duplicates = split_duplicates(models)
    chosen_splits, split_report = _file_splits(splits, categories, models, unique)
    n_found = len(unique) + len(duplicates)
    if max_models is not None:
        unique = spread_over_categories(unique, max_models)
        duplicates = []
    by_id = {model.model_id: chosen_splits[model.name] if chosen_splits is not None
             else split_of(model, split_seed) for model in unique}
    return ModelSelection(root=root, models=unique, duplicates=duplicates, splits=by_id,
                          split_file=split_report, n_found=n_found)


def _file_splits(
    splits: str | os.PathLike[str] | None, categories: Iterable[str] | None,
    models: list[SourceModel], unique: list[SourceModel],
) -> tuple[dict[str, str] | None, SplitFileReport | None]:
    """The split of each unique model from the split file, and how the file matched."""
    if splits is None:
        return None, None
    path = as_path(splits, "splits")
    listed = read_split_file(path, None if categories is None else list(categories))
    unplaced = [model.source for model in unique if model.name not in listed]
    if unplaced:
        shown = ", ".join(unplaced[:5]) + (", ..." if len(unplaced) > 5 else "")
        raise InputError(
            f"{path}: does not place {len(unplaced)} of the {len(unique)} models of the "
            f"source ({shown}); add them to the file or leave them out with categories"
        )
    found = {model.name for model in models}
    chosen = {model.name: "val" if published_split(listed[model.name]) == "validation"
              else listed[model.name] for model in unique}
    report = SplitFileReport(path=path, n_placed=len(chosen),
                             not_in_source=tuple(sorted(set(listed) - found)))
    return chosen, report


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
    splits: str | os.PathLike[str] | None = None,
    max_models: int | None = None,
) -> dict[str, Any]:
    """Validate the options that define the result; return them as JSON types.

    A split file enters as the SHA-256 of its bytes (``splits_sha256``), so a
    resumed build with an edited file is refused like one with another seed.
    """
    if format not in FORMATS:
        raise InputError(f"format: expected one of {', '.join(FORMATS)}, got {format!r}")
    import vptoolkit

    if remesh and not clean:
        raise InputError("remesh: remeshing is a cleaning step; it needs clean=True")
    return {
        "format": format,
        "n_views": check_int(n_views, "n_views", minimum=1),
        "resolution": check_int(resolution, "resolution", minimum=1, maximum=16384),
        "n_points": check_int(n_points, "n_points", minimum=1),
        "max_faces": check_int(max_faces, "max_faces", minimum=4),
        "clean": check_bool(clean, "clean"),
        "remesh": check_bool(remesh, "remesh"),
        "split_seed": check_int(split_seed, "split_seed", minimum=None),
        "splits_sha256": None if splits is None else _file_sha256(as_path(splits, "splits")),
        "max_models": None if max_models is None else check_int(max_models, "max_models",
                                                                minimum=1),
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


COMPILE_NOTICE = "compiling the rasteriser (first run only, about 30 s)"
"""The stderr line of a build whose first model compiles the numba kernel."""


def _say_if_compiling() -> None:
    """Print :data:`COMPILE_NOTICE` on stderr when numba has no usable cache of the kernel."""
    from vptoolkit._numba import will_compile
    from vptoolkit.visibility._raster import rasterize_batch

    if will_compile(rasterize_batch):
        print(COMPILE_NOTICE, file=sys.stderr, flush=True)


def _file_sha256(path: Path) -> str:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError as err:
        raise InputError(f"{path}: cannot read the split file ({err.strerror or err})") from err


def _store_attrs(options: Mapping[str, Any], *, source: str, created: str,
                 split_file: SplitFileReport | None = None) -> dict[str, Any]:
    extra: dict[str, Any] = {}
    if split_file is not None:
        extra["split_file"] = {"name": split_file.path.name,
                               "sha256": options["splits_sha256"]}
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
        **extra,
    }


def _task(model: SourceModel, options: Mapping[str, Any]) -> ModelTask:
    """The plain, picklable arguments of one model's work."""
    return ModelTask(
        path=str(model.path),
        source=model.source,
        category=model.category,
        name=model.name,
        n_views=options["n_views"],
        resolution=options["resolution"],
        n_points=options["n_points"],
        max_faces=options["max_faces"],
        clean=options["clean"],
        remesh=options["remesh"],
        seed=model_seed(options["split_seed"], model.model_id),
        signature=source_signature(model),
    )
