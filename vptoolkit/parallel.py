"""Run one function over many tasks in worker processes or on a Dask cluster.

:func:`run_tasks` is the package's one process pool and
:func:`run_on_cluster` its Dask runner; both yield the results as the tasks
complete (not in task order), so a caller writes each result out and drops
it. The function must be a top-level function of a picklable task, and the
caller says what a task that cannot finish yields: ``crashed(task)`` for a
task whose worker process died twice, ``failed(task, error)`` for a task the
cluster lost. A function that is part of a deterministic pipeline must
derive everything from its task, never from the worker or the order.

Local pool (:func:`run_tasks`)
    ``workers`` processes, started with ``forkserver`` (``spawn`` where
    there is none); at most ``2 * workers`` tasks are in flight, and
    ``tasks`` is read only as places free up, so memory stays flat however
    many tasks there are. Each worker runs numba with one thread (``workers``
    processes of all threads each would oversubscribe the cores) and ends
    when the calling process ends, even after ``kill -9``: on Linux the
    kernel kills it (``PR_SET_PDEATHSIG``), everywhere a watchdog thread
    checks every second that the caller is alive.

Crashes
    A worker that dies (a crash in a native library, the out-of-memory
    killer) breaks the whole pool, and the tasks in flight cannot tell which
    of them killed it. Each of them is then run again alone, one at a time in
    a one-process pool that is replaced when it breaks; a task that kills
    that process too yields ``crashed(task)``. A fresh pool then takes the
    remaining tasks.

Dask (:func:`run_on_cluster`)
    Sends the tasks to a running ``distributed`` scheduler, at most 1024
    at once (``tasks`` is read only as results come back, so memory stays
    flat), each run with one numba thread, and releases each result once it
    is yielded. A Dask nanny starts its workers with
    ``MALLOC_TRIM_THRESHOLD_=65536``, which also fixes glibc's mmap threshold
    at 128 KiB: every array above that is then a fresh ``mmap`` whose pages
    fault in anew (about ten times the page faults of a plain process, and
    more CPU time in a search). The first task in such a worker sets
    glibc's thresholds to the ceiling of its own dynamic ones (mmap above
    32 MiB, trim above 64 MiB), so the heap is reused as in a plain process.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import multiprocessing
import os
import re
import secrets
import sys
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

from vptoolkit.checks import check_int
from vptoolkit.errors import InputError
from vptoolkit.optional import is_available, require

__all__ = ["check_scheduler_address", "run_on_cluster", "run_tasks"]

Task = TypeVar("Task")
Result = TypeVar("Result")

_CONNECT_TIMEOUT = "30s"  # to reach a Dask scheduler
# Dask's comm protocols; http:// (a dashboard) and bare words are refused before connecting.
_SCHEDULER_ADDRESS = re.compile(
    r"(?:(?:tcp|tls|ws|wss|ucx)://)?(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):\d{1,5}"
    r"|inproc://\S+"
)
_PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>
_WATCHDOG_SECONDS = 1.0
_CLUSTER_WINDOW = 1024  # tasks submitted to a Dask scheduler at once
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # mallopt's parameters, from glibc's <malloc.h>
_MMAP_THRESHOLD_MAX = 32 * 2**20  # glibc's largest dynamic mmap threshold on 64-bit systems


# --------------------------------------------------------------------------- local processes


def run_tasks(
    function: Callable[[Task], Result],
    tasks: Iterable[Task],
    *,
    workers: int,
    crashed: Callable[[Task], Result],
) -> Iterator[Result]:
    """Yield ``function(task)`` for every task, from ``workers`` processes.

    Parameters
    ----------
    function : callable
        A top-level function (pickled by reference) of one task. It should
        catch its own errors and return them as results: an exception it
        raises ends the iteration.
    tasks : iterable
        Picklable tasks, read lazily as workers free up.
    workers : int
        Worker processes; 1 (or fewer than two tasks) runs every task in this
        process, with no protection against a crash and numba left alone.
    crashed : callable
        Called in this process with a task whose worker died twice (see the
        module docstring); its return value is that task's result.

    Yields
    ------
    object
        One result per task, in the order the tasks complete.

    Raises
    ------
    InputError
        If ``workers`` is not a positive integer.
    """
    workers = check_int(workers, "workers", minimum=1)
    queue = iter(tasks)
    first = list(itertools.islice(queue, 2))
    if workers == 1 or len(first) < 2:
        for task in itertools.chain(first, queue):
            yield function(task)
        return
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    numbered = enumerate(itertools.chain(first, queue))
    window = 2 * workers
    while True:
        broken: list[tuple[int, Task]] = []
        with _pool(workers, context) as pool:
            running: dict[Future[Result], tuple[int, Task]] = {}
            is_exhausted = False
            while not broken:
                while not is_exhausted and len(running) < window:
                    item = next(numbered, None)
                    if item is None:
                        is_exhausted = True
                        break
                    try:
                        running[pool.submit(function, item[1])] = item
                    except BrokenProcessPool:  # a worker died since the last wait
                        broken.append(item)
                        break
                if broken:
                    break
                if not running:
                    return
                completed, _ = wait(running, return_when=FIRST_COMPLETED)
                for future in completed:
                    item = running.pop(future)
                    try:
                        result = future.result()
                    except BrokenProcessPool:
                        broken.append(item)
                    else:
                        yield result
            broken.extend(running.values())
        yield from _run_alone([task for _, task in sorted(broken, key=lambda item: item[0])],
                              function, crashed, context)


def _run_alone(
    tasks: list[Task],
    function: Callable[[Task], Result],
    crashed: Callable[[Task], Result],
    context: Any,
) -> Iterator[Result]:
    """Run each task alone in a one-process pool, replaced whenever a task kills it."""
    pending = deque(tasks)
    while pending:
        with _pool(1, context) as pool:
            while pending:
                task = pending.popleft()
                try:
                    result = pool.submit(function, task).result()
                except BrokenProcessPool:
                    yield crashed(task)
                    break
                yield result


def _pool(workers: int, context: Any) -> ProcessPoolExecutor:
    return ProcessPoolExecutor(max_workers=workers, mp_context=context,
                               initializer=_start_worker, initargs=(os.getpid(),))


def _start_worker(parent_pid: int) -> None:
    """Initializer of every worker process: one numba thread, and end with the parent.

    A worker started by the ``forkserver`` is the server's child, not the
    caller's, so a caller killed with ``kill -9`` would leave its workers
    (each holding a mesh and numba's buffers) running forever. On Linux the
    kernel sends SIGKILL to the worker when its parent dies
    (``PR_SET_PDEATHSIG``, through ctypes); everywhere, a daemon thread
    checks every second that the caller is alive and exits the worker if not.
    """
    import signal
    import threading

    if "numba" not in sys.modules:
        os.environ["NUMBA_NUM_THREADS"] = "1"  # read when numba is first imported
    else:
        from vptoolkit._numba import numba

        numba.set_num_threads(1)

    if sys.platform.startswith("linux"):
        import ctypes

        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)

    def watch() -> None:
        while True:
            time.sleep(_WATCHDOG_SECONDS)
            try:
                os.kill(parent_pid, 0)
            except ProcessLookupError:
                os._exit(1)
            except PermissionError:  # pragma: no cover - pid reused by another user
                os._exit(1)

    threading.Thread(target=watch, name="vptoolkit-worker-watchdog", daemon=True).start()


# --------------------------------------------------------------------------- Dask


def check_scheduler_address(address: Any) -> str:
    """Check the address of a Dask scheduler before connecting to it.

    Parameters
    ----------
    address : str
        ``tcp://host:port`` (or ``tls://``, ``ws://``, ``wss://``,
        ``ucx://``, ``inproc://``; a bare ``host:port`` is tcp).

    Returns
    -------
    str
        The address without surrounding spaces.

    Raises
    ------
    InputError
        If ``address`` is not a string or not a scheduler address (e.g. a
        dashboard's ``http://``).
    """
    if not isinstance(address, str) or not address.strip():
        raise InputError(
            f"scheduler: expected an address such as tcp://host:8786, got {address!r}"
        )
    if not _SCHEDULER_ADDRESS.fullmatch(address.strip()):
        raise InputError(
            f"scheduler: {address!r} is not a Dask scheduler address; expected "
            "tcp://host:port (or tls://, ws://, wss://, ucx://, inproc://)"
        )
    return address.strip()


def run_on_cluster(
    function: Callable[[Task], Result],
    tasks: Iterable[Task],
    *,
    address: str,
    failed: Callable[[Task, Exception], Result],
    name: Callable[[Task], str],
) -> Iterator[Result]:
    """Yield ``function(task)`` for every task, computed on a Dask cluster.

    Parameters
    ----------
    function : callable
        A top-level function of one task, importable on the workers.
    tasks : iterable
        Picklable tasks; the workers must see the files they name under the
        same paths.
    address : str
        The scheduler (see :func:`check_scheduler_address`).
    failed : callable
        Called in this process with a task and the error of a lost worker
        or cancelled task; its return value is that task's result.
    name : callable
        Readable start of a task's Dask key; a random suffix keeps keys unique.

    Yields
    ------
    object
        As :func:`run_tasks` does.

    Raises
    ------
    InputError
        If the scheduler cannot be reached within 30 seconds.
    MissingDependencyError
        If ``distributed`` is not installed.
    """
    distributed = require("distributed", extra="cluster")
    try:
        client = distributed.Client(address, set_as_default=False, timeout=_CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as err:
        raise InputError(f"scheduler: cannot connect to {address} ({err})") from err
    try:
        queue = iter(tasks)
        futures: dict[Any, Task] = {}

        def submit(task: Task) -> Any:
            future = client.submit(_in_dask_worker, function, task,
                                   key=f"{name(task)}-{secrets.token_hex(4)}", pure=False)
            futures[future] = task
            return future

        completed = distributed.as_completed(
            [submit(task) for task in itertools.islice(queue, _CLUSTER_WINDOW)],
            loop=client.loop)
        for future in completed:
            task = futures.pop(future)
            try:
                result = future.result()
            # A lost worker or a cancelled task is the cluster's failure, not the task's.
            except Exception as err:  # noqa: BLE001
                result = failed(task, err)
            future.release()
            for following in itertools.islice(queue, 1):  # one in for one out
                completed.add(submit(following))
            yield result
    finally:
        client.close()


def _in_dask_worker(function: Callable[[Task], Result], task: Task) -> Result:
    """Run a task on a Dask worker thread with one numba thread (the setting is per
    thread) and glibc's heap reused (:func:`_reuse_heap`)."""
    _reuse_heap()
    if is_available("numba"):
        from vptoolkit._numba import numba

        numba.set_num_threads(1)
    return function(task)


@functools.cache
def _reuse_heap() -> None:
    """Undo the fixed malloc thresholds that ``MALLOC_TRIM_THRESHOLD_`` sets (once per process).

    Setting glibc's trim threshold turns off its dynamic mmap threshold,
    which otherwise rises to the size of freed blocks (at most 32 MiB, the
    trim threshold following at twice that), so large arrays come from the
    heap again instead of fresh ``mmap`` calls. Where the variable is unset
    (a plain process, a Dask worker configured without it) glibc's dynamic
    thresholds are left alone; off glibc ``mallopt`` is absent or a no-op.
    """
    if "MALLOC_TRIM_THRESHOLD_" not in os.environ or not sys.platform.startswith("linux"):
        return
    import ctypes

    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None)
        libc.mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD_MAX)
        libc.mallopt(_M_TRIM_THRESHOLD, 2 * _MMAP_THRESHOLD_MAX)
