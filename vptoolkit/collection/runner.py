"""Run one method over a whole collection: parallel, bounded, resumable, failures recorded.

:func:`run_collection` answers every entry of a source
(:func:`vptoolkit.collection.discover.discover`) with one method
(:mod:`vptoolkit.collection.methods`) and writes ``OUT/<digest>/``:

``settings.json``
    The method's record and the face limit; ``<digest>`` is the first 16 hex
    digits of its SHA-256, so changed settings go to a new folder and are
    never mixed with the old answers.
``staging/``
    One JSON record per finished entry, written atomically
    (:func:`vptoolkit.files.atomic_write`) as soon as it finishes, named by
    the SHA-256 of its key and its file's SHA-256 (streamed): a rerun with
    the same settings skips every entry whose record exists, so ``kill -9``
    loses only the entries in flight, and a changed file is answered again.
``table.parquet``
    :func:`vptoolkit.collection.table.write_table`, written at the end from
    the staged records in discovery order: the same bytes whatever the
    worker count, the scheduler, the order of completion or a resume.
``timings.jsonl``
    One line per entry answered by this run (appended; timings differ from
    run to run, so they stay out of the table): ``{"key", "seconds", "read",
    "answer", "draw", "finish", "stage"}``, the seconds of reading the file,
    of the method's answer and of ``draw`` (in the worker, e.g. drawing a
    thumbnail and encoding its PNG), of ``finish`` (in this process, e.g.
    writing that PNG) and of writing the staged record, and ``seconds``
    their sum.

Work
    Entries are hashed in this process and answered by
    :func:`vptoolkit.parallel.run_tasks` (``workers`` processes, at most
    twice as many tasks in flight) or :func:`vptoolkit.parallel.run_on_cluster`
    (a Dask scheduler's workers, which must see the files under the same
    paths), one :class:`EntryTask` each. What a worker makes of an answer
    (``draw``) comes back with it as bytes, so that this process stays the
    one writer of the output folder and ``finish`` has only to write.

Limits
    A file with more than ``max_faces`` faces (default :data:`MAX_MODEL_FACES`)
    (a point cloud: more points) is refused after reading, before any view
    is drawn; a point cloud of more than ``max_points`` points (default
    :data:`~vptoolkit.point_cloud.MAX_POINTS`) is first thinned on reading
    (:func:`vptoolkit.io.load`), with a warning naming the file. An entry that takes
    longer than ``timeout`` seconds (default :data:`TIMEOUT_S`) is stopped by
    a ``SIGALRM`` timer in its worker (``signal.setitimer``; it interrupts
    Python code between native calls, so one native call runs to its end,
    and a hung native call is never stopped) and recorded as failed; the
    timer's exception is a ``BaseException``, so no ``except Exception`` of
    a reader can take it for a read error. On a Dask worker thread no timer
    can be set and the cluster's own limits apply.

Failures
    An entry that cannot be read, is a point cloud (no search draws a cloud
    yet), is too large or cannot be answered is a ``failed`` row with a
    one-line reason, and the run goes on. Failures that depend on the file
    and the settings alone are staged like answers; those that may not
    happen again (a timeout, a dead worker, a lost cluster task, a file that
    could not be read) are not, so a rerun tries them again.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from vptoolkit.checks import as_path, check_bool, check_int, one_line
from vptoolkit.collection.discover import (
    Entry,
    discover,
    is_remote_entry,
)
from vptoolkit.collection.methods import Answer, Method
from vptoolkit.collection.table import write_table
from vptoolkit.conventions import PICTURE_UP
from vptoolkit.errors import InputError, VptoolkitError
from vptoolkit.files import (
    atomic_write,
    exclusive_lock,
    json_text,
    read_json_file,
    sha256_file,
)
from vptoolkit.mesh import Mesh
from vptoolkit.parallel import check_scheduler_address, run_on_cluster, run_tasks
from vptoolkit.point_cloud import MAX_POINTS, PointCloud
from vptoolkit.progress import progress_bar

__all__ = ["MAX_MODEL_FACES", "TIMEOUT_S", "CollectionRun", "EntryResult", "EntryTask",
           "answer_entry", "read_model", "run_collection", "settings_digest"]

MAX_MODEL_FACES = 2_000_000
"""Default face limit: a model with more faces is refused before any view is drawn."""

TIMEOUT_S = 600.0
"""Default wall-clock limit of one entry, in seconds."""

TABLE_NAME = "table.parquet"
SETTINGS_NAME = "settings.json"
TIMINGS_NAME = "timings.jsonl"
_ORDER_NAME = "order.jsonl"
_LOCK_NAME = ".lock"


class _TimeLimit(BaseException):
    """Raised in a worker by the entry's timer (not an ``Exception``: no reader's
    ``except Exception`` takes it for its own error)."""


@dataclass(frozen=True)
class EntryTask:
    """One entry to answer: the file, its key and hash, the method and the limits, and
    what the worker does with the answer (``draw``, see :func:`run_collection`)."""

    entry: Entry
    sha256: str
    method: Method
    max_faces: int
    timeout: float
    max_points: int = MAX_POINTS
    keep_model: bool = False
    draw: Callable[[EntryResult], EntryResult] | None = None


@dataclass(frozen=True)
class EntryResult:
    """What one entry gave: an answer or a one-line reason, and its time.

    ``is_staged`` says whether the outcome depends on the file and settings
    alone (staged, never tried again) or may change (a timeout, a lost
    worker: tried again by the next run). ``seconds`` is the worker's time,
    ``read_seconds`` its part spent reading the file and ``draw_seconds``
    its part spent in ``draw``. ``model`` and ``answer.detail`` are there
    for a caller that draws (``keep_model``) and ``output`` for the one that
    writes what ``draw`` made (e.g. a PNG's bytes); none of them is stored.
    """

    entry: Entry
    sha256: str
    answer: Answer | None = None
    reason: str = ""
    seconds: float = 0.0
    read_seconds: float = 0.0
    is_staged: bool = True
    model: Mesh | PointCloud | None = field(default=None, compare=False)
    draw_seconds: float = 0.0
    output: bytes = field(default=b"", compare=False, repr=False)

    def record(self) -> dict[str, Any]:
        """The JSON record staged and written as a table row."""
        record: dict[str, Any] = {"file": self.entry.path, "key": self.entry.key,
                                  "sha256": self.sha256,
                                  "status": "failed" if self.answer is None else "ok",
                                  "reason": self.reason, "views": 0, "label": ""}
        if self.answer is not None:
            answer = self.answer
            record.update(views=int(answer.views), label=answer.label,
                          directions=answer.directions.tolist(),
                          raw=[None if value != value else float(value) for value in answer.raw],
                          poses=answer.poses.reshape(len(answer.poses), 16).tolist(),
                          intrinsics=answer.intrinsics.reshape(9).tolist())
        return record


@dataclass(frozen=True)
class CollectionRun:
    """What :func:`run_collection` did.

    Attributes
    ----------
    folder : Path
        ``OUT/<digest>``, with ``settings.json``, ``staging/``, the table and the timings.
    table : Path
        ``table.parquet``: one row per entry (see :mod:`vptoolkit.collection.table`).
    n_entries : int
        Entries discovered.
    n_done : int
        Entries answered (this run or before).
    n_resumed : int
        Entries found staged by an earlier run, not answered again.
    failures : tuple of (str, str)
        ``(key, one-line reason)`` of every failed entry, in discovery order.
    """

    folder: Path
    table: Path
    n_entries: int
    n_done: int
    n_resumed: int
    failures: tuple[tuple[str, str], ...]


def settings_digest(method: Method, max_faces: int,
                    max_points: int = MAX_POINTS) -> tuple[str, dict[str, Any]]:
    """The output folder's name and its ``settings.json`` for a method and the read limits.

    The digest is the first 16 hex digits of the SHA-256 of the record's
    canonical JSON (sorted keys, no spaces). ``image_up`` names the image up of
    the table's camera poses (``PICTURE_UP``, or a search's own ``up``), so a
    folder whose poses put another axis up is never resumed into. ``max_points``
    (how far a point cloud is thinned on reading, which changes its answers) is
    recorded only when it is not :data:`~vptoolkit.point_cloud.MAX_POINTS`, so the
    folder of the default settings keeps its name.
    """
    record: dict[str, Any] = {"method": method.record(), "max_faces": max_faces,
                              "image_up": list(PICTURE_UP)}
    if max_points != MAX_POINTS:
        record["max_points"] = max_points
    text = json.dumps(record, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16], record


def read_model(path: str, max_points: int = MAX_POINTS) -> Mesh | PointCloud:
    """Read one collection entry as the model its method takes.

    The one place a collection reads a file: through
    :func:`vptoolkit.inputs.read_model`, which decides by content and thins a
    cloud of more than ``max_points`` points (:func:`vptoolkit.io.load`). A point
    cloud goes to every method (the search, every view measured, a view set:
    the session splats it) and to the pictures (the software engine splats
    it too); a URL (remote entries are not fetched) is refused in one line.

    Raises
    ------
    InputError
        A :class:`~vptoolkit.errors.MeshLoadError` naming the file and problem,
        or the refusal of a URL.
    """
    from vptoolkit.inputs import read_model as read_input

    if is_remote_entry(path):
        raise InputError(f"{path}: a URL; collections read local files only")
    return read_input(path, max_points=max_points)


def answer_entry(task: EntryTask) -> EntryResult:
    """Worker: read, check and answer one entry, then ``task.draw`` it, within its limits
    (top level, picklable)."""
    started = time.perf_counter()
    read = 0.0
    with _time_limit(task.timeout):
        try:
            mesh = read_model(task.entry.path, task.max_points)
            read = time.perf_counter() - started
            count, kind = ((mesh.n_points, "points") if isinstance(mesh, PointCloud)
                           else (mesh.n_faces, "faces"))
            if count > task.max_faces:
                raise InputError(f"{task.entry.key}: {count} {kind}, more than the "
                                 f"limit of {task.max_faces} (--max-faces)")
            answer = task.method(mesh)
            result = EntryResult(task.entry, task.sha256, answer, read_seconds=read, model=mesh)
            answered = time.perf_counter()
            if task.draw is not None:
                result = task.draw(result)
        except _TimeLimit:
            return EntryResult(task.entry, task.sha256,
                               reason=f"{task.entry.key}: took longer than {task.timeout:g} s "
                                      "(--timeout)",
                               seconds=time.perf_counter() - started, read_seconds=read,
                               is_staged=False)
        except (VptoolkitError, OSError, MemoryError) as err:
            return EntryResult(task.entry, task.sha256, reason=one_line(err),
                               seconds=time.perf_counter() - started, read_seconds=read,
                               is_staged=not isinstance(err, (OSError, MemoryError)))
    ended = time.perf_counter()
    return replace(result, seconds=ended - started,
                   draw_seconds=ended - answered if task.draw is not None else 0.0,
                   model=result.model if task.keep_model else None)


class _time_limit:  # noqa: N801 - a context manager, used like a function
    """Raise :class:`_TimeLimit` in this thread after ``seconds`` (main thread only)."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.is_armed = (hasattr(signal, "setitimer")
                         and threading.current_thread() is threading.main_thread())

    def __enter__(self) -> None:
        if self.is_armed:
            self.previous = signal.signal(signal.SIGALRM, self._expire)
            signal.setitimer(signal.ITIMER_REAL, self.seconds)

    def __exit__(self, *exc: object) -> None:
        if self.is_armed:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self.previous)

    @staticmethod
    def _expire(signum: int, frame: object) -> None:
        raise _TimeLimit


def _worker_died(task: EntryTask) -> EntryResult:
    return EntryResult(task.entry, task.sha256,
                       reason=f"{task.entry.key}: the worker process died while answering it",
                       is_staged=False)


def _cluster_lost(task: EntryTask, error: Exception) -> EntryResult:
    return EntryResult(task.entry, task.sha256,
                       reason=f"{task.entry.key}: lost on the cluster ({one_line(error)})",
                       is_staged=False)


def _timing(result: EntryResult, finish: float, stage: float) -> dict[str, Any]:
    """One line of ``timings.jsonl``: the entry's seconds by stage and in all."""
    stages = {"read": result.read_seconds,
              "answer": result.seconds - result.read_seconds - result.draw_seconds,
              "draw": result.draw_seconds, "finish": finish, "stage": stage}
    return {"key": result.entry.key, "seconds": round(result.seconds + finish + stage, 4),
            **{name: round(seconds, 4) for name, seconds in stages.items()}}


def _staged_path(staging: Path, key: str, sha256: str) -> Path:
    name = hashlib.sha256(f"{key}\n{sha256}".encode()).hexdigest()
    return staging / name[:2] / f"{name}.json"


def _hashed(entry: Entry) -> tuple[str, str]:
    """The file's SHA-256, or ``("", reason)`` when it cannot be read."""
    if is_remote_entry(entry.path):
        return "", ""
    try:
        return sha256_file(entry.path), ""
    except (OSError, InputError) as err:
        return "", f"{entry.key}: cannot read ({one_line(getattr(err, 'strerror', None) or err)})"


def run_collection(
    source: str | os.PathLike[str],
    out: str | os.PathLike[str],
    method: Method,
    *,
    max_faces: int = MAX_MODEL_FACES,
    max_points: int = MAX_POINTS,
    timeout: float = TIMEOUT_S,
    workers: int = 1,
    scheduler: str | None = None,
    draw: Callable[[EntryResult], EntryResult] | None = None,
    finish: Callable[[EntryResult], EntryResult] | None = None,
    progress: bool = False,
) -> CollectionRun:
    """Answer every entry of ``source`` with ``method`` into ``out/<digest>/``, resumably.

    Parameters
    ----------
    source : str or path-like
        A folder, a glob or ``@list.txt`` (:func:`vptoolkit.collection.discover.discover`).
    out : path-like
        The output folder; the run writes ``out/<digest>/`` (module docstring).
    method : Method
        What every entry gets (:mod:`vptoolkit.collection.methods`).
    max_faces : int
        Refuse a model with more faces (default: :data:`MAX_MODEL_FACES`).
    max_points : int
        Thin a point cloud of more points on reading, as :func:`vptoolkit.io.load`
        (default: :data:`~vptoolkit.point_cloud.MAX_POINTS`); part of the digest
        when not the default.
    timeout : float
        Seconds one entry may take (default: :data:`TIMEOUT_S`).
    workers : int
        Local worker processes, as ``build-dataset --workers`` (default: 1,
        in this process).
    scheduler : str, optional
        A running Dask scheduler's address, as ``build-dataset --scheduler``;
        not with ``workers > 1``.
    draw : callable, optional
        Called in the worker with every answered entry and its model, within
        the entry's time limit, e.g. to draw its picture; returns the result
        that comes back, which may be a failure or carry ``output`` bytes
        for ``finish`` to write. It must be picklable (a top-level class's
        instance) and derive everything from its entry, so its output is the
        same whatever the worker, as the table is.
    finish : callable, optional
        Called in this process with every answered entry before it is staged
        (with its model when there is no ``draw``, e.g. to draw it in this
        process; with ``draw``'s ``output``, e.g. to write it); returns the
        result to stage, which may be a failure.
    progress : bool
        A progress bar on stderr: files per second and time left (default: False).

    Returns
    -------
    CollectionRun

    Raises
    ------
    InputError
        On a bad option, a source that does not exist, ``workers > 1`` with
        ``scheduler``, a method that must run in this process with either,
        or an unreachable scheduler.
    MissingDependencyError
        If pyarrow (or, with ``scheduler``, distributed) is not installed.
    """
    from vptoolkit.optional import require

    require("pyarrow", extra="dataset")
    workers = check_int(workers, "workers", minimum=1)
    max_faces = check_int(max_faces, "max_faces", minimum=1)
    max_points = check_int(max_points, "max_points", minimum=1)
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not timeout > 0:
        raise InputError(f"timeout: expected a positive number of seconds, got {timeout!r}")
    progress = check_bool(progress, "progress")
    if scheduler is not None:
        scheduler = check_scheduler_address(scheduler)
        if workers != 1:
            raise InputError("workers: give either workers > 1 or scheduler, not both")
    if method.in_process and (workers != 1 or scheduler is not None):
        raise InputError("workers: this method runs in this process; drop workers and scheduler")
    n_entries = sum(1 for _ in discover(source))  # a first pass: the bar's total, streamed
    digest, record = settings_digest(method, max_faces, max_points)
    folder = as_path(out, "out") / digest
    staging = folder / "staging"
    staging.mkdir(parents=True, exist_ok=True)
    with exclusive_lock(folder / _LOCK_NAME, f"{folder}: another run is writing this folder"):
        return _run(source, folder, record, method, n_entries, max_faces, max_points,
                    float(timeout), workers, scheduler, draw, finish, progress)


def _run(source: str | os.PathLike[str], folder: Path, record: dict[str, Any], method: Method,
         n_entries: int, max_faces: int, max_points: int, timeout: float, workers: int,
         scheduler: str | None,
         draw: Callable[[EntryResult], EntryResult] | None,
         finish: Callable[[EntryResult], EntryResult] | None, progress: bool) -> CollectionRun:
    """The body of :func:`run_collection`, with the folder locked."""
    staging = folder / "staging"
    with atomic_write(folder / SETTINGS_NAME) as stream:
        stream.write(json_text(record).encode())

    counts = {"resumed": 0}
    unstaged: dict[tuple[str, str], str] = {}
    order_partial = folder / f".{_ORDER_NAME}.partial"

    def tasks() -> Iterator[EntryTask]:
        with order_partial.open("w", encoding="utf-8") as order:
            for entry in discover(source):
                sha256, unreadable = _hashed(entry)
                order.write(json.dumps([entry.path, entry.key, sha256]) + "\n")
                if unreadable:
                    unstaged[(entry.key, sha256)] = unreadable
                    bar.update(1)
                    continue
                if _staged_path(staging, entry.key, sha256).exists():
                    counts["resumed"] += 1
                    bar.update(1)
                    continue
                yield EntryTask(entry, sha256, method, max_faces, timeout, max_points,
                                keep_model=finish is not None and draw is None, draw=draw)

    with progress_bar(total=n_entries, description="files", unit="file",
                      enabled=progress) as bar, \
            (folder / TIMINGS_NAME).open("a", encoding="utf-8") as timings:
        results = (
            run_on_cluster(answer_entry, tasks(), address=scheduler, failed=_cluster_lost,
                           name=lambda task: "vptoolkit-collection")
            if scheduler is not None
            else run_tasks(answer_entry, tasks(), workers=workers, crashed=_worker_died))
        for result in results:
            started = time.perf_counter()
            if finish is not None and result.answer is not None:
                result = finish(result)
            finished = time.perf_counter()
            if result.is_staged:
                target = _staged_path(staging, result.entry.key, result.sha256)
                target.parent.mkdir(exist_ok=True)
                with atomic_write(target) as stream:
                    stream.write(json_text(result.record(), indent=None).encode())
            else:
                unstaged[(result.entry.key, result.sha256)] = result.reason
            timings.write(json.dumps(_timing(result, finished - started,
                                             time.perf_counter() - finished)) + "\n")
            timings.flush()
            bar.update(1)
    os.replace(order_partial, folder / _ORDER_NAME)

    failures: list[tuple[str, str]] = []
    done = itertools.count()

    def rows() -> Iterator[dict[str, Any]]:
        with (folder / _ORDER_NAME).open(encoding="utf-8") as order:
            for line in order:
                path, key, sha256 = json.loads(line)
                staged = _staged_path(staging, key, sha256)
                if (key, sha256) in unstaged or not staged.exists():
                    reason = unstaged.get((key, sha256), f"{key}: not answered")
                    row = EntryResult(Entry(path, key), sha256, reason=reason).record()
                else:  # the path as this run's source names it, whatever an earlier one said
                    row = {**read_json_file(staged), "file": path}
                if row["status"] == "ok":
                    next(done)
                else:
                    failures.append((key, row["reason"]))
                yield row

    table = write_table(folder / TABLE_NAME, rows(), method.names)
    return CollectionRun(folder, table, n_entries, next(done), counts["resumed"],
                         tuple(failures))

