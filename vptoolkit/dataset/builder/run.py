"""Build a viewpoint-quality dataset from a folder of meshes, resumably.

:func:`build_dataset` turns a source tree into one store (see
``vptoolkit/dataset_card/SCHEMA.md``) as one
:class:`~vptoolkit.dataset.builder.options.BuildOptions` value says. Per model
it loads the mesh, cleans it (unless ``options.clean`` is False), samples
``options.n_points`` surface points with their normals, computes VE, VR,
VKL and VMI over the ``options.measure`` views and keeps the result; then
it writes ``OUT/dataset.zarr`` or ``OUT/dataset.h5`` with
:func:`vptoolkit.dataset.store.writer.write_dataset`. This module is the
orchestration; its parts live beside it:

- :mod:`vptoolkit.dataset.builder.sources`: finding the mesh files, model ids,
  categories, duplicate names, splits and per-model seeds;
- :mod:`vptoolkit.dataset.builder.split_files`: a published split read from a file
  (``splits``) instead of the seeded one;
- :mod:`vptoolkit.dataset.builder.staging`: the resumable ``OUT/.staging`` folder,
  its files and their validation (how a killed build resumes);
- :mod:`vptoolkit.dataset.builder.compute`: what one model's task does (load,
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

import logging
import os
import sys
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vptoolkit.checks import as_path, check_bool, check_int
from vptoolkit.dataset.builder.compute import (
    FailedModel,
    ModelTask,
    cluster_lost,
    process_model,
    worker_died,
)
from vptoolkit.dataset.builder.options import BuildOptions, SplitFile
from vptoolkit.dataset.builder.sources import (
    SPLIT_FRACTIONS,
    SourceModel,
    discover_models,
    model_seed,
    models_outside,
    split_duplicates,
    split_of,
    spread_over_categories,
)
from vptoolkit.dataset.builder.split_files import read_split_file
from vptoolkit.dataset.builder.staging import (
    build_lock,
    prepare_out,
    resume_or_start,
    scan_staging,
    source_signature,
    stage_failure,
    stage_key,
    stage_model,
    staged_entries,
    warn_about_models_left_out,
)
from vptoolkit.dataset.store.schema import published_split
from vptoolkit.dataset.store.writer import write_dataset
from vptoolkit.errors import InputError
from vptoolkit.optional import is_available, require
from vptoolkit.parallel import check_scheduler_address, run_on_cluster, run_tasks
from vptoolkit.progress import progress_bar

__all__ = [
    "COMPILE_NOTICE",
    "STAGES",
    "BuildResult",
    "SplitFileReport",
    "build_dataset",
]

_log = logging.getLogger(__name__)

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
    options: BuildOptions = BuildOptions(),
    *,
    categories: Iterable[str] | None = None,
    workers: int = 1,
    scheduler: str | None = None,
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
    options : BuildOptions
        What defines the dataset: the measure settings, points, cleaning,
        split seed or split file, ``max_models`` and the store format
        (default: ``BuildOptions()``). A build folder is resumed only with
        equal options.
    categories : iterable of str, optional
        Build only these categories (default: all); with a split file in the
        authors' ``small.txt`` layout, also the categories its rule counts.
    workers : int
        Local worker processes (default: 1, in this process).
    scheduler : str, optional
        Address of a running Dask distributed scheduler, e.g.
        ``"tcp://127.0.0.1:8786"``; its workers must see ``src`` under the
        same path (default: None, run locally).
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
        The store's path, counts, failures and seconds; with a split file,
        how many models it placed and which of its names the source lacks
        (:attr:`BuildResult.split_file`).

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
    options = _check_build_options(options)
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

    selection = select_models(src, out_dir, options, categories=categories)
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

        entries = staged_entries(
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
        store_path = out_dir / options.store_name
        started_store = time.perf_counter()
        write_dataset(
            store_path,
            entries,
            attrs=_store_attrs(options, source=root.name, created=created),
            views=options.measure.directions(),
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
    src: str | os.PathLike[str], out_dir: Path, options: BuildOptions, *,
    categories: Iterable[str] | None,
) -> ModelSelection:
    """Discover the models of ``src`` and choose those a build with these options takes."""
    models = discover_models(src, categories)
    root = as_path(src, "src").resolve()
    models = models_outside(models, out_dir)
    unique, duplicates = split_duplicates(models)
    chosen_splits, split_report = _file_splits(options.splits, categories, models, unique)
    n_found = len(unique) + len(duplicates)
    if options.max_models is not None:
        unique = spread_over_categories(unique, options.max_models)
        duplicates = []
    by_id = {model.model_id: chosen_splits[model.name] if chosen_splits is not None
             else split_of(model, options.split_seed) for model in unique}
    return ModelSelection(root=root, models=unique, duplicates=duplicates, splits=by_id,
                          split_file=split_report, n_found=n_found)


def _file_splits(
    splits: SplitFile | None, categories: Iterable[str] | None,
    models: list[SourceModel], unique: list[SourceModel],
) -> tuple[dict[str, str] | None, SplitFileReport | None]:
    """The split of each unique model from the split file, and how the file matched."""
    if splits is None:
        return None, None
    if splits.path is None:
        raise InputError("splits: a split file rebuilt from a record has no path to read")
    path = splits.path
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


def _check_build_options(options: BuildOptions) -> BuildOptions:
    if not isinstance(options, BuildOptions):
        raise InputError(f"options: expected BuildOptions, got {type(options).__name__}")
    return options


def _check_dependencies(options: BuildOptions, scheduler: str | None) -> None:
    """Fail before any work when a needed package is missing, instead of failing every model."""
    # h5py is a core dependency (plain `pip install vptoolkit`); zarr comes with [dataset].
    needed: list[tuple[str, str | None]] = [
        ("zarr", "dataset") if options.format == "zarr" else ("h5py", None)
    ]
    if options.clean:
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


def _store_attrs(options: BuildOptions, *, source: str, created: str) -> dict[str, Any]:
    import vptoolkit  # the package imports this module: its version is read at call time

    return {
        **options.store_attrs(),
        "split_fractions": dict(SPLIT_FRACTIONS),
        "source": source,
        "toolkit_version": vptoolkit.__version__,
        "created": created,
    }


def _task(model: SourceModel, options: BuildOptions) -> ModelTask:
    """The picklable arguments of one model's work."""
    return ModelTask(
        path=str(model.path),
        source=model.source,
        category=model.category,
        name=model.name,
        options=options,
        seed=model_seed(options.split_seed, model.model_id),
        signature=source_signature(model),
    )
