"""Size a build before it runs: its models per category and split, and an estimate.

:func:`plan_build` finds the models a :func:`~vptoolkit.dataset.builder.run.build_dataset`
call with the same :class:`~vptoolkit.dataset.builder.options.BuildOptions` would
take, counts them per category and split, and builds a few of them
(``calibrate``) into a temporary folder with the same options. The
calibration models are spread over the file sizes: with the ``n`` models
sorted by size, the ``k`` chosen sit at ``floor((i + 1/2) n / k)``, the
midpoints of ``k`` equal-count size strata, so a collection whose first
models are small (or large) is not misjudged. The wall seconds of that
calibration build per model and its bytes per model, scaled to all the
models, are the estimate. With several ``workers`` the calibration draws
with one numba thread, as each worker process does, and the estimate is
the seconds of those models in one such process, shared among the workers;
with one worker it draws with all of numba's threads, as the build will.
The estimate: the seconds of one process (as ``workers=1``), those seconds
shared among ``workers`` processes (at most one per CPU and per model: the
work of a model is not split, and two processes on one core take turns), and
the bytes of the build folder (its staging files plus the store). It is an estimate from
a few models: sizes vary from mesh to mesh. Before the timed models, the
first of them is built once at a tiny resolution and point count, so the
compilation of the numba kernels on a first run is not counted.
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from vptoolkit.checks import as_path, check_int
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.builder.sources import SourceModel

__all__ = ["CALIBRATION_MODELS", "BuildPlan", "plan_build", "size_strata"]

CALIBRATION_MODELS = 8
"""Models :func:`plan_build` builds for its estimate unless told otherwise."""


@dataclass(frozen=True)
class BuildPlan:
    """What :func:`plan_build` found and estimated.

    Attributes
    ----------
    counts : dict
        ``{category: {"train": n, "val": n, "test": n}}``, sorted by category.
    n_models : int
        Models the build would take.
    n_duplicates : int
        Files with a duplicate name (failures of the build).
    n_found : int
        Models of the source after ``categories``, before ``max_models``.
    n_calibrated : int
        Models built to make the estimate (0 with ``calibrate=0``).
    n_calibration_failures : int
        Of those, how many failed (not counted in the per-model figures).
    seconds_per_model, bytes_per_model : float or None
        Wall seconds of the calibration build per calibration model (load,
        clean, sample, measure, write; a failed model's time counts too) and
        build-folder bytes of a built model; None when none was built.
    workers : int
        Processes the estimate shares the work among: the build's
        ``workers``, at most the CPU count and the model count (at least 1).
    """

    counts: dict[str, dict[str, int]]
    n_models: int
    n_duplicates: int
    n_found: int
    n_calibrated: int = 0
    n_calibration_failures: int = 0
    seconds_per_model: float | None = None
    bytes_per_model: float | None = None
    workers: int = 1

    @property
    def estimated_seconds(self) -> float | None:
        """Seconds of the whole build in one process, or None without calibration."""
        if self.seconds_per_model is None:
            return None
        return self.seconds_per_model * self.n_models

    @property
    def estimated_wall_seconds(self) -> float | None:
        """Seconds of the whole build with :attr:`workers` processes, or None without
        calibration."""
        if self.estimated_seconds is None:
            return None
        return self.estimated_seconds / self.workers

    @property
    def estimated_bytes(self) -> float | None:
        """Bytes of the whole build folder, or None without calibration."""
        if self.bytes_per_model is None:
            return None
        return self.bytes_per_model * self.n_models

    def lines(self) -> list[str]:
        """The plan as text: one line per category, totals, then the estimate."""
        width = max((len(category) for category in self.counts), default=8)
        rows = [f"{'category':<{width}}  {'train':>6} {'val':>6} {'test':>6}"]
        for category, split in self.counts.items():
            rows.append(f"{category:<{width}}  {split['train']:>6} {split['val']:>6} "
                        f"{split['test']:>6}")
        totals = {name: sum(split[name] for split in self.counts.values())
                  for name in ("train", "val", "test")}
        rows.append(f"{'total':<{width}}  {totals['train']:>6} {totals['val']:>6} "
                    f"{totals['test']:>6}")
        subset = (f" (a subset of the {self.n_found} found)"
                  if self.n_found != self.n_models + self.n_duplicates else "")
        rows.append(f"{self.n_models} models to build{subset}, {self.n_duplicates} "
                    "duplicate names (failures)")
        if self.seconds_per_model is None or self.bytes_per_model is None:
            if self.n_calibrated:
                rows.append(f"no estimate: all {self.n_calibrated} calibration models failed")
            return rows
        rows.append(
            f"estimate from {self.n_calibrated - self.n_calibration_failures} calibration "
            f"models: about {_hours(self.estimated_seconds)} in one process "
            f"({self.seconds_per_model:.1f} s a model)"
            + (f", about {_hours(self.estimated_wall_seconds)} with {self.workers} worker "
               "processes" if self.workers > 1 else "")
            + f", and {_size(self.estimated_bytes)} on disk ({_size(self.bytes_per_model)} "
            "a model)"
        )
        return rows


def plan_build(
    src: str | os.PathLike[str],
    out: str | os.PathLike[str],
    options: BuildOptions = BuildOptions(),
    *,
    categories: Iterable[str] | None = None,
    calibrate: int = CALIBRATION_MODELS,
    workers: int = 1,
    progress: bool = False,
) -> BuildPlan:
    """List the models a build would take and estimate its hours and disk.

    ``options`` and ``categories`` are those of
    :func:`~vptoolkit.dataset.builder.run.build_dataset`; ``out`` is only read
    (models inside it are left out, as the build leaves them out).
    ``calibrate`` models are built into a temporary folder that is deleted
    afterwards (0: count only). ``workers`` is the build's process count,
    for the wall-time estimate (:attr:`BuildPlan.workers`).

    Returns
    -------
    BuildPlan
        Counts per category and split, and the estimate.

    Raises
    ------
    InputError
        As :func:`~vptoolkit.dataset.builder.run.build_dataset` for bad options or
        sources.
    """
    from vptoolkit._numba import max_threads, threads
    from vptoolkit.dataset.builder.run import _check_build_options, build_dataset, select_models

    options = _check_build_options(options)
    calibrate = check_int(calibrate, "calibrate", minimum=0)
    workers = check_int(workers, "workers", minimum=1)
    selection = select_models(src, as_path(out, "out"), options, categories=categories)
    counts: dict[str, dict[str, int]] = {}
    for model in selection.models:
        row = counts.setdefault(model.category, {"train": 0, "val": 0, "test": 0})
        row[selection.splits[model.model_id]] += 1
    plan = BuildPlan(counts=dict(sorted(counts.items())), n_models=len(selection.models),
                     n_duplicates=len(selection.duplicates), n_found=selection.n_found,
                     workers=max(1, min(workers, os.cpu_count() or 1, len(selection.models))))
    n_calibrate = min(calibrate, len(selection.models))
    if n_calibrate == 0:
        return plan
    with tempfile.TemporaryDirectory(prefix="vptoolkit-plan-") as folder:
        # The same code paths on a small problem: numba compiles (or loads) its kernels here.
        measure = options.measure
        tiny = replace(options, measure=replace(measure, views=min(measure.views, 8),
                                                resolution=min(measure.resolution, 16)),
                       n_points=min(options.n_points, 50), max_models=1)
        build_dataset(selection.root, Path(folder) / "warm-up", tiny, categories=categories,
                      progress=False, compile_notice=progress)
        chosen = size_strata(selection.models, n_calibrate)
        sources = Path(folder) / "src"
        for model in chosen:
            link = sources / model.source
            link.parent.mkdir(parents=True, exist_ok=True)
            link.symlink_to(model.path)
        trial = Path(folder) / "build"
        started = time.perf_counter()
        # A worker of a build with several processes draws with one numba thread;
        # one process alone draws with all of them.
        with threads(1 if plan.workers > 1 else max_threads()):
            result = build_dataset(sources, trial, replace(options, max_models=None),
                                   progress=progress)
        wall = time.perf_counter() - started
        n_bytes = sum(path.stat().st_size for path in trial.rglob("*") if path.is_file())
    n_built = result.n_computed
    if n_built == 0:
        return _with(plan, n_calibrate, result.n_failures, None, None)
    return _with(plan, n_calibrate, n_calibrate - n_built, wall / n_calibrate,
                 n_bytes / n_built)


def size_strata(models: Sequence[SourceModel], k: int) -> list[SourceModel]:
    """``k`` of ``models`` spread over their file sizes: the midpoints of ``k`` size strata.

    With the models sorted by ``(size, source)``, the ``i``-th chosen is at
    ``floor((i + 1/2) n / k)``; with ``k >= n`` every model is chosen.

    """
    by_size = sorted(models, key=lambda model: (model.path.stat().st_size, model.source))
    n = len(by_size)
    if k >= n:
        return by_size
    return [by_size[int((i + 0.5) * n / k)] for i in range(k)]


def _with(plan: BuildPlan, n_calibrated: int, n_failed: int, seconds: float | None,
          n_bytes: float | None) -> BuildPlan:
    return replace(plan, n_calibrated=n_calibrated, n_calibration_failures=n_failed,
                   seconds_per_model=seconds, bytes_per_model=n_bytes)


def _hours(seconds: float | None) -> str:
    seconds = seconds or 0.0
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def _size(n_bytes: float | None) -> str:
    value = float(n_bytes or 0.0)
    for unit in ("B", "KB", "MB", "GB"):
        if value < 1000:
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1000
    return f"{value:.1f} TB"
