"""Thumbnails for a folder of meshes, from each mesh's best (or a predicted) view.

:func:`render_thumbnails` draws one picture per mesh file below a folder:
the measures (:func:`vptoolkit.measures.quality.compute_view_quality`) run in
parallel worker processes while one renderer (an
:class:`~vptoolkit.pictures.engine.Engine`) draws, so a start-up such as
that of Open3D's render child is paid once. The picture of ``SRC/a/b.off``
is ``OUT/a/b.png``; ``OUT/thumbnails.json`` records the measure, the
measure settings, the size, every picture's direction and the files that were skipped with their
one-line reasons (unreadable, unmeasurable or undrawable files never stop
the batch). The measuring runs in :func:`vptoolkit.parallel.run_tasks`, one
frozen :class:`_MeasureTask` per file, each giving a :class:`_Measured`.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vptoolkit.checks import as_path, check_int, one_line
from vptoolkit.errors import InputError, VptoolkitError
from vptoolkit.files import write_json_atomic
from vptoolkit.measures.registry import canonical_name
from vptoolkit.mesh import Mesh
from vptoolkit.parallel import run_tasks
from vptoolkit.pictures.engine import Engine, drawing_engine
from vptoolkit.pictures.png import save_png
from vptoolkit.pictures.views import DirectionSource, resolve_direction
from vptoolkit.progress import progress_bar
from vptoolkit.settings import MeasureSettings, check_settings

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from vptoolkit.view_sets.result import ViewSet

__all__ = ["ThumbnailFailure", "ThumbnailResult", "render_thumbnails"]

_INDEX_NAME = "thumbnails.json"


@dataclass(frozen=True)
class ThumbnailFailure:
    """A mesh file that got no thumbnail.

    Attributes
    ----------
    source : str
        Path of the file relative to the source folder.
    reason : str
        One line: what went wrong.
    """

    source: str
    reason: str


@dataclass(frozen=True)
class ThumbnailResult:
    """What :func:`render_thumbnails` did.

    Attributes
    ----------
    done : list of Path
        The written PNG files, sorted.
    failures : list of ThumbnailFailure
        The skipped files with their reasons, sorted by source.
    index : Path
        ``thumbnails.json`` in the output folder: measure, measure settings
        (:meth:`~vptoolkit.settings.MeasureSettings.to_dict`), size and
        one ``{"source", "image", "direction", "label"}`` record per picture,
        plus the failures.
    """

    done: list[Path] = field(default_factory=list)
    failures: list[ThumbnailFailure] = field(default_factory=list)
    index: Path | None = None


def _mesh_files(source: Path) -> list[Path]:
    """``source`` itself if a file, else its mesh files (hidden ones skipped), sorted."""
    from vptoolkit.io import find_mesh_files

    if source.is_file():
        return [source]
    if not source.is_dir():
        raise InputError(f"{source}: no such file or folder")
    return find_mesh_files(source)


@dataclass(frozen=True)
class _MeasureTask:
    """One mesh file to measure: where it is, how it is named in the index, and the settings."""

    path: str
    source: str
    measure: str
    settings: MeasureSettings
    view_set: int | None


@dataclass(frozen=True)
class _Measured:
    """The mesh of one task and the direction(s) to draw it from, or why there are none."""

    source: str
    error: str | None = None
    mesh: Mesh | None = None
    direction: NDArray[np.float64] | None = None
    label: str = ""
    view_set: ViewSet | None = None


def _best_direction_task(task: _MeasureTask) -> _Measured:
    """Worker: load a mesh and find its best view or view set (top level, so a pool can run it)."""
    from vptoolkit.inputs import read_model
    from vptoolkit.measures.quality import compute_view_quality

    try:
        mesh = read_model(task.path, requires="surface")
        if task.view_set:
            from vptoolkit.view_sets.search import measure_view_set

            _, view_set = measure_view_set(mesh, task.view_set, settings=task.settings)
            label = f"view set of {len(view_set)} ({100 * view_set.coverage[-1]:.1f} % seen)"
            return _Measured(task.source, mesh=mesh, direction=view_set.directions,
                             view_set=view_set, label=label)
        quality = compute_view_quality(mesh, task.settings, measures=(task.measure,))
    except (VptoolkitError, OSError, MemoryError) as err:
        return _Measured(task.source, error=one_line(err))
    index = int(quality.best_index[0])
    return _Measured(task.source, mesh=mesh, direction=quality.views[index],
                     label=f"best {task.measure} (view {index} of {len(quality.views)})")


def _worker_died(task: _MeasureTask) -> _Measured:
    """What a task yields whose worker process died twice (``run_tasks``'s ``crashed``)."""
    return _Measured(task.source, error="the worker process died while measuring it")


def _rounded(direction: Any) -> list[Any]:
    """A direction (or, for a view set, each direction) as a list of 6-decimal floats."""
    array = np.asarray(direction, dtype=np.float64)
    if array.ndim == 2:
        return [_rounded(row) for row in array]
    return [round(float(c), 6) for c in array]


def _predicted_results(tasks: list[_MeasureTask], predictor: DirectionSource,
                       measure: str) -> Iterator[_Measured]:
    from vptoolkit.inputs import read_model

    for task in tasks:
        try:
            mesh = read_model(task.path, requires="surface")
            direction = resolve_direction(mesh, predictor, measure=measure)
        except (VptoolkitError, OSError, MemoryError) as err:
            yield _Measured(task.source, error=one_line(err))
            continue
        yield _Measured(task.source, mesh=mesh, direction=direction, label=f"predicted {measure}")


def _draw(result: _Measured, engine: Engine, settings: MeasureSettings,
          output_of: dict[str, Path], target: Path, done: list[Path],
          failures: list[ThumbnailFailure]) -> dict[str, Any] | None:
    """Draw and save one measured mesh; its index record, or None after recording a failure."""
    if result.error is not None or result.mesh is None or result.direction is None:
        failures.append(ThumbnailFailure(result.source, result.error or "nothing to draw"))
        return None
    image_path = output_of[result.source]
    try:
        if result.view_set is not None:
            from vptoolkit.pictures.contact_sheet import view_set_sheet

            image, _ = view_set_sheet(result.mesh, view_set=result.view_set,
                                      settings=settings, engine=engine)
        else:
            image = engine.render(result.mesh, result.direction)[0]
        image_path.parent.mkdir(parents=True, exist_ok=True)
        done.append(save_png(image, image_path))
    except (VptoolkitError, OSError) as err:
        failures.append(ThumbnailFailure(result.source, one_line(err)))
        return None
    return {"source": result.source, "image": image_path.relative_to(target).as_posix(),
            "direction": _rounded(result.direction), "label": result.label}


def render_thumbnails(
    src: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    measure: str = "VE",
    predictor: DirectionSource | None = None,
    workers: int | None = None,
    settings: MeasureSettings | None = None,
    engine: Engine | None = None,
    progress: bool = False,
    view_set: int | None = None,
) -> ThumbnailResult:
    """Draw a thumbnail of every mesh in a folder from its best (or predicted) view.

    Every file below ``src`` with a suffix :func:`vptoolkit.io.load_mesh`
    reads (:func:`vptoolkit.io.find_mesh_files`: hidden files and folders are
    skipped) is loaded, measured (:func:`vptoolkit.measures.quality.compute_view_quality`)
    and drawn from its best view for ``measure``; with ``predictor`` the
    direction comes from it instead and nothing is measured. The picture of
    ``src/a/b.off`` is ``out/a/b.png``. Measuring runs in ``workers``
    processes (numba limited to one thread each); one engine draws, started
    once.

    Parameters
    ----------
    src : path-like
        A folder (searched recursively, in sorted order) or one mesh file.
    out : path-like
        Output folder, created if needed.
    measure : str
        Any registered measure name, in any case (default: "VE"); with
        ``predictor``, one it predicts.
    predictor : (3,) or (M, 3) array_like, or callable, optional
        Direction source (see :func:`vptoolkit.pictures.views.resolve_direction`);
        a callable gets each :class:`~vptoolkit.mesh.Mesh`, e.g. a trained
        network's prediction.
    workers : int, optional
        Measuring processes (default: the number of CPUs; 1 measures in this
        process with every numba thread).
    settings : MeasureSettings, optional
        How the measures draw each mesh (default: ``MeasureSettings()``:
        1000 views, 1024 px, ``Camera()``).
    engine : Engine, optional
        The engine that draws, its size the thumbnails' side; its camera
        must be that of ``settings`` (default: a software engine of 512
        pixels with that camera, made for this call).
    progress : bool
        Show a progress bar on stderr (default: False).
    view_set : int, optional
        Draw each mesh's ``view_set``-view coverage set
        (:func:`vptoolkit.view_sets.search.best_view_set`) as a captioned contact
        sheet (:func:`vptoolkit.pictures.contact_sheet.view_set_sheet`), a tile
        of the engine's size per view, instead of one view; its record lists
        every direction.

    Returns
    -------
    ThumbnailResult
        Written pictures, skipped files with reasons, and the index file.

    Raises
    ------
    InputError
        If ``src`` does not exist, an argument is invalid, the engine's
        camera is not that of ``settings``, or two sources would write the
        same picture (``a.off`` and ``a.obj``: the second is
        reported as a failure instead).
    MissingDependencyError
        If the engine cannot start here (checked before any work).
    """
    source = as_path(src, "src")
    target = as_path(out, "out")
    measure = canonical_name(measure)
    workers = check_int(os.cpu_count() or 1 if workers is None else workers, "workers", minimum=1)
    settings = MeasureSettings() if settings is None else check_settings(settings)
    if view_set is not None:
        view_set = check_int(view_set, "view_set", minimum=1)
        if predictor is not None:
            raise InputError("view_set: a predictor gives one view per mesh; drop one of them")
    files = _mesh_files(source)
    root = source if source.is_dir() else source.parent
    target.mkdir(parents=True, exist_ok=True)

    tasks: list[_MeasureTask] = []
    failures: list[ThumbnailFailure] = []
    output_of: dict[str, Path] = {}
    claimed: dict[Path, str] = {}
    for path in files:
        relative = path.relative_to(root).as_posix()
        image_path = target / Path(relative).with_suffix(".png")
        if image_path in claimed:
            failures.append(ThumbnailFailure(
                relative, f"same thumbnail name as {claimed[image_path]} ({image_path.name})"))
            continue
        claimed[image_path] = relative
        output_of[relative] = image_path
        tasks.append(_MeasureTask(str(path), relative, measure, settings, view_set))

    records: list[dict[str, Any]] = []
    done: list[Path] = []
    with drawing_engine(engine, camera=settings.camera) as active:
        active.start()  # fail fast, in one line, when no engine can run here
        results = (run_tasks(_best_direction_task, tasks, workers=workers, crashed=_worker_died)
                   if predictor is None else _predicted_results(tasks, predictor, measure))
        with progress_bar(total=len(tasks), description="thumbnails", unit="model",
                          enabled=progress) as bar:
            for result in results:
                bar.update(1)
                record = _draw(result, active, settings, output_of, target, done, failures)
                if record is not None:
                    records.append(record)
        size = active.size
    failures.sort(key=lambda failure: failure.source)
    records.sort(key=lambda record: record["source"])
    index = target / _INDEX_NAME
    write_json_atomic(index, {
        "source": str(source),
        "measure": measure,
        "direction_from": "measures" if predictor is None else "predictor",
        "settings": settings.to_dict(),
        "size": size,
        "thumbnails": records,
        "failures": [{"source": f.source, "reason": f.reason} for f in failures],
    }, sort_keys=False)
    return ThumbnailResult(sorted(done), failures, index)
