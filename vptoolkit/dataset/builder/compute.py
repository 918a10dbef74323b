"""What one model's build task does: load, clean, measure and sample, timing each stage.

:func:`process_model` is the function a build runs for every model, in this
process, in a worker process or on a Dask worker
(:mod:`vptoolkit.parallel`). It gets a picklable :class:`ModelTask` and
returns a :class:`MeasuredModel` (the arrays of one
:class:`~vptoolkit.dataset.store.schema.ModelEntry` in schema dtypes, its record
and the seconds per stage) or a :class:`FailedModel` with a one-line reason;
it never raises. The caller stages the result
(:mod:`vptoolkit.dataset.builder.staging`).

A file that :func:`vptoolkit.io.load` reads as a point cloud is measured on
its points (the measures defined on points only), is not cleaned, stores
points taken from its own (:func:`vptoolkit.cloud_sample.sample_cloud`) and
zero vertices and faces.

Determinism
    Everything comes from the task: the point sample is seeded with
    ``task.seed`` (from the split seed and the model id), and the cleaning
    report is kept without its timings, so the same task gives the same
    arrays and record in any process.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import one_line
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.errors import InputError, MissingDependencyError, VptoolkitError
from vptoolkit.files import sha256_file
from vptoolkit.point_cloud import PointCloud

if TYPE_CHECKING:
    from vptoolkit.cloud_sample import CloudSample
    from vptoolkit.measures.quality import ViewQuality
    from vptoolkit.mesh import Mesh
    from vptoolkit.view_sets.result import ViewSet

__all__ = [
    "VIEW_SET_VIEWS",
    "FailedModel",
    "MeasuredModel",
    "ModelResult",
    "ModelTask",
    "TaskOutcome",
    "cluster_lost",
    "process_model",
    "worker_died",
]

VIEW_SET_VIEWS = 6
"""Most views in each model's stored coverage view set (SCHEMA.md, "Model record")."""


@dataclass(frozen=True)
class ModelTask:
    """The picklable arguments of one model's work.

    Attributes
    ----------
    path : str
        Absolute path of the mesh file.
    source : str
        Path relative to the source folder, with ``/`` separators.
    category, name : str
        The model's category and name.
    options : BuildOptions
        The build's options: measure settings, the measures, surface points, cleaning.
    seed : int
        Seed of the point sample.
    signature : dict
        What identifies the source file in the staging folder (model id,
        source, size, modification time), passed through to the result.
    """

    path: str
    source: str
    category: str
    name: str
    options: BuildOptions
    seed: int
    signature: dict[str, Any]

    @property
    def model_id(self) -> str:
        """Stable id ``category/name``."""
        return f"{self.category}/{self.name}"


@dataclass(frozen=True)
class TaskOutcome:
    """What every result of a :class:`ModelTask` names: its model and source.

    Attributes
    ----------
    model_id : str
        ``category/name``.
    signature : dict
        The task's source signature.
    """

    model_id: str
    signature: dict[str, Any]


@dataclass(frozen=True)
class MeasuredModel(TaskOutcome):
    """A model measured in full (``model_id``, ``signature``: :class:`TaskOutcome`).

    Attributes
    ----------
    record : dict
        ``name``, ``category``, ``source``, ``source_sha256``,
        ``n_vertices``, ``n_faces``, ``cleaning`` (report without timings, or
        None) and ``view_set``.
    arrays : dict of str to ndarray
        The :class:`~vptoolkit.dataset.store.schema.ModelEntry` arrays in schema
        dtypes (``points``, ``normals``, ``quality``, ``quality_raw``,
        ``best_index``, ``best_value``, ``worst_index``, ``worst_value``,
        ``vertices``, ``faces``).
    seconds : dict of str to float
        Wall-clock seconds of ``load``, ``clean``, ``measure`` and
        ``sample``: reported, never stored.
    """

    record: dict[str, Any]
    arrays: dict[str, NDArray[Any]]
    seconds: dict[str, float]


@dataclass(frozen=True)
class FailedModel(TaskOutcome):
    """A model that could not be measured (``model_id``, ``signature``: :class:`TaskOutcome`).

    Attributes
    ----------
    failure : dict of str to str
        ``{"source", "category", "reason"}``, the reason one line.
    is_staged : bool
        Whether the failure belongs to the model and is kept in the staging
        folder; False for the environment's failures (a missing package, no
        memory, a dead worker, a lost cluster task), which the next run
        tries again (default: True).
    """

    failure: dict[str, str]
    is_staged: bool = True


ModelResult = MeasuredModel | FailedModel
"""What :func:`process_model` returns."""


def process_model(task: ModelTask) -> ModelResult:
    """Load, clean, sample and measure one model; never raises.

    A top-level function of plain arguments, so local process pools and Dask
    workers can run it. The caller writes the staged file.

    Parameters
    ----------
    task : ModelTask
        The model and the options.

    Returns
    -------
    MeasuredModel or FailedModel
        The arrays, record and seconds, or the one-line reason.
    """
    try:
        return _measure_model(task)
    # The worker's environment or load, not the model: recorded but not staged, so
    # the next run tries the model again.
    except MissingDependencyError as err:
        return failed_model(task, f"{task.source}: {one_line(err)}", is_staged=False)
    except MemoryError:
        return failed_model(task, f"{task.source}: out of memory", is_staged=False)
    except VptoolkitError as err:
        return failed_model(task, _with_source(task.source, one_line(err)))
    except OSError as err:
        return failed_model(task, _os_error_reason(task, err))
    # This is the one place a broad except is right: an unexpected bug on one
    # model of thousands must not stop the batch; it is recorded with its type.
    except Exception as err:  # noqa: BLE001
        return failed_model(
            task, f"{task.source}: unexpected {type(err).__name__}: {one_line(err)}"
        )


def _measure_model(task: ModelTask) -> MeasuredModel:
    from vptoolkit.io import load

    path = Path(task.path)
    seconds: dict[str, float] = {}
    started = time.perf_counter()
    source_sha256 = sha256_file(path)
    model = load(path, max_points=task.options.max_points)
    seconds["load"] = time.perf_counter() - started
    if isinstance(model, PointCloud):
        arrays, cleaning, view_set = _cloud_arrays(model, task, seconds)
    else:
        arrays, cleaning, view_set = _mesh_arrays(model, task, seconds)
    record = {
        "name": task.name,
        "category": task.category,
        "source": task.source,
        "source_sha256": source_sha256,
        "n_vertices": len(arrays["vertices"]),
        "n_faces": len(arrays["faces"]),
        "cleaning": cleaning,
        "view_set": view_set.record(),
    }
    return MeasuredModel(
        model_id=task.model_id,
        signature=task.signature,
        record=record,
        arrays=arrays,
        seconds=seconds,  # wall-clock per stage: reported, never stored
    )


def _mesh_arrays(mesh: Mesh, task: ModelTask, seconds: dict[str, float]
                 ) -> tuple[dict[str, NDArray[Any]], dict[str, Any] | None, ViewSet]:
    """A mesh's arrays (cleaned, measured, sampled on its faces), cleaning report and view set."""
    from vptoolkit.clean import clean_mesh
    from vptoolkit.points import sample_surface

    options = task.options
    cleaning = None
    started = time.perf_counter()
    if options.clean:
        mesh, report = clean_mesh(mesh, max_faces=options.max_faces, remesh=options.remesh)
        cleaning = _without_timings(report.to_dict())
    seconds["clean"] = time.perf_counter() - started
    started = time.perf_counter()
    quality, view_set = _quality_and_view_set(mesh, options)
    seconds["measure"] = time.perf_counter() - started
    started = time.perf_counter()
    sample = (_scan_sample(mesh, options.n_points, task.seed) if options.sampling == "scan"
              else sample_surface(mesh, options.n_points, seed=task.seed))
    seconds["sample"] = time.perf_counter() - started
    arrays = _arrays(quality, sample.points, sample.normals, mesh.vertices, mesh.faces)
    return arrays, cleaning, view_set


def _scan_sample(mesh: Mesh, n_points: int, seed: int) -> CloudSample:
    """``n_points`` points of a virtual scan of ``mesh`` (``BuildOptions.sampling="scan"``).

    The default scanner (:func:`vptoolkit.scan.virtual_scan`, seeded with
    ``seed``), then :func:`vptoolkit.cloud_sample.sample_cloud`'s rule with the
    same seed; each point keeps the normal of the face under it.
    """
    from vptoolkit.cloud_sample import sample_cloud
    from vptoolkit.scan import virtual_scan

    points, normals = virtual_scan(mesh, seed=seed)
    if not len(points):
        raise InputError(f"{mesh.name}: no scanner sees the mesh, nothing to sample")
    return sample_cloud(PointCloud(points, normals, name=mesh.name), n_points, seed=seed)


def _cloud_arrays(cloud: PointCloud, task: ModelTask, seconds: dict[str, float]
                  ) -> tuple[dict[str, NDArray[Any]], None, ViewSet]:
    """A point cloud's arrays, no cleaning report and its view set.

    The measures are those of its points (splatted, each weighing the area it
    stands for); a measure not defined on points is an InputError naming it.
    The stored points are :func:`~vptoolkit.cloud_sample.sample_cloud`'s; a
    cloud has no surface, so it stores zero vertices and zero faces and is
    not cleaned.
    """
    from vptoolkit.cloud_sample import sample_cloud

    seconds["clean"] = 0.0
    started = time.perf_counter()
    quality, view_set = _quality_and_view_set(cloud, task.options)
    seconds["measure"] = time.perf_counter() - started
    started = time.perf_counter()
    sample = sample_cloud(cloud, task.options.n_points, seed=task.seed)
    seconds["sample"] = time.perf_counter() - started
    arrays = _arrays(quality, sample.points, sample.normals, np.zeros((0, 3)),
                     np.zeros((0, 3), dtype=np.int64))
    return arrays, None, view_set


def _arrays(quality: ViewQuality, points: NDArray[np.float64], normals: NDArray[np.float64],
            vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> dict[str, NDArray[Any]]:
    """One model's arrays (:data:`~vptoolkit.dataset.store.schema.ENTRY_ARRAYS`), schema dtypes."""
    columns = np.arange(quality.raw.shape[1])
    raw = quality.raw.astype(np.float32)
    return {
        "points": points.astype(np.float32),
        "normals": normals.astype(np.float32),
        "quality": quality.normalized.astype(np.float32),
        "quality_raw": raw,
        "best_index": quality.best_index.astype(np.int64),
        "best_value": raw[quality.best_index, columns],
        "worst_index": quality.worst_index.astype(np.int64),
        "worst_value": raw[quality.worst_index, columns],
        "vertices": vertices.astype(np.float32),
        "faces": faces.astype(np.int32),
    }


def _quality_and_view_set(model: Mesh | PointCloud, options: BuildOptions
                          ) -> tuple[ViewQuality, ViewSet]:
    """The build's measures of a model and its coverage view set, from one drawing of its views.

    The views are drawn once (with the depth and silhouette statistics only when
    a chosen measure needs them; a point cloud's points splatted by a
    :class:`~vptoolkit.measures.session.MeasuringSession`, which refuses a
    measure not defined on points); the measures
    (:func:`~vptoolkit.measures.quality.compute_view_quality` with
    ``measures=options.measures``: the paper's four streamed from the pixel
    counts, any others from the registry) and the greedy coverage set of
    :data:`VIEW_SET_VIEWS` views (:func:`~vptoolkit.view_sets.search.best_view_set`)
    read the same pixel counts, as :func:`~vptoolkit.view_sets.search.measure_view_set`
    does for the four. A cloud's coverage counts the area its points stand for.
    """
    from vptoolkit.geometry import face_areas
    from vptoolkit.measures.quality import compute_view_quality
    from vptoolkit.measures.registry import get_measure
    from vptoolkit.measures.session import MeasuringSession
    from vptoolkit.view_sets.search import best_view_set
    from vptoolkit.view_sets.visibility import FaceVisibility
    from vptoolkit.visibility import iter_view_histograms

    settings = options.measure
    directions = settings.directions()
    if isinstance(model, PointCloud):
        session = MeasuringSession(model, options.measures, settings)
        runs = tuple(session.draw(directions))
        areas = session.areas
    else:
        features = any(get_measure(name).needs_image_statistics for name in options.measures)
        runs = tuple(iter_view_histograms(model, settings, view_directions=directions,
                                          features=features))
        areas = face_areas(model)
    visibility = FaceVisibility(directions, areas, runs, model.name)
    quality = compute_view_quality(model, settings, measures=options.measures,
                                   view_directions=visibility.views, histograms=runs)
    return quality, best_view_set(visibility, VIEW_SET_VIEWS)


def failed_model(task: ModelTask, reason: str, *, is_staged: bool = True) -> FailedModel:
    """The :class:`FailedModel` of a task, with a one-line ``reason``."""
    return FailedModel(
        model_id=task.model_id,
        signature=task.signature,
        failure={"source": task.source, "category": task.category, "reason": reason},
        is_staged=is_staged,
    )


def worker_died(task: ModelTask) -> FailedModel:
    """Result of a task whose worker process died twice (``crashed`` of a local pool)."""
    return failed_model(
        task, f"{task.source}: the worker process died while processing it", is_staged=False
    )


def cluster_lost(task: ModelTask, error: Exception) -> FailedModel:
    """Result of a task the cluster lost (``failed`` of :func:`~vptoolkit.parallel.run_on_cluster`).

    A lost worker or a cancelled task is the cluster's failure, not the
    model's: it is recorded for this run without staging it, so a rerun
    retries.
    """
    return failed_model(
        task,
        f"{task.source}: cluster task failed ({type(error).__name__}: {one_line(error)})",
        is_staged=False,
    )


def _os_error_reason(task: ModelTask, error: OSError) -> str:
    """The reason of a file that cannot be read, named by its path under SRC.

    The absolute path of the build machine (and a symbolic link's target)
    stays out of the failures and so out of the card.
    """
    path = Path(task.path)
    if path.is_symlink() and not path.exists():
        return f"{task.source}: dangling symbolic link (its target does not exist)"
    if error.filename is not None and Path(str(error.filename)) != path:
        return f"{task.source}: unexpected {type(error).__name__}: {one_line(error)}"
    return f"{task.source}: cannot read ({error.strerror or type(error).__name__})"


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
