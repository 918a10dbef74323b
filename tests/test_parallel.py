"""The process pool and the Dask address check of vptoolkit.parallel."""

from __future__ import annotations

import os
import sys
import time

import pytest

from fixtures.environment import DASK_DASHBOARD, require_package
from vptoolkit.errors import InputError
from vptoolkit.parallel import check_scheduler_address, run_on_cluster, run_tasks


def _square(number: int) -> int:
    return number * number


def _square_or_die(number: int) -> int:
    """Kills its worker process on 3, like a crash in a native library."""
    if number == 3:
        os._exit(11)
    return number * number


def _page_faults_of_arrays(n_arrays: int) -> tuple[str | None, int]:
    """Dask's ``MALLOC_TRIM_THRESHOLD_`` here, and the minor page faults of ``n_arrays``
    arrays of 1 MiB made and freed in turn."""
    import resource

    import numpy as np

    np.ones(2**17)  # the first may grow the heap
    before = resource.getrusage(resource.RUSAGE_THREAD).ru_minflt
    for _ in range(n_arrays):
        np.ones(2**17)
    faults = resource.getrusage(resource.RUSAGE_THREAD).ru_minflt - before
    return os.environ.get("MALLOC_TRIM_THRESHOLD_"), faults


def _pid_and_threads(number: int) -> tuple[int, int]:
    from vptoolkit._numba import numba

    return os.getpid(), numba.get_num_threads()


def test_one_worker_runs_in_this_process_in_order():
    assert list(run_tasks(_square, range(5), workers=1, crashed=repr)) == [0, 1, 4, 9, 16]
    assert list(run_tasks(_pid_and_threads, [0], workers=4, crashed=repr)) == [
        _pid_and_threads(0)
    ]


def test_workers_are_other_processes_with_one_numba_thread():
    results = list(run_tasks(_pid_and_threads, range(4), workers=2, crashed=repr))
    assert len(results) == 4
    assert all(pid != os.getpid() and threads == 1 for pid, threads in results)


@pytest.mark.slow
def test_a_crashing_task_yields_what_the_caller_says_and_the_rest_go_on():
    results = list(run_tasks(_square_or_die, range(8), workers=2, crashed=lambda n: f"died {n}"))
    assert sorted(results, key=str) == sorted([0, 1, 4, "died 3", 16, 25, 36, 49], key=str)


def _square_or_die_late(number: int) -> int:
    """Kills its worker on 0 after a moment, while the caller is busy with another result."""
    if number == 0:
        time.sleep(0.3)
        os._exit(11)
    return number * number


@pytest.mark.slow
def test_a_worker_dying_between_submissions_is_retried_not_raised():
    # The pool breaks while the caller holds a result; the next submission
    # then finds it broken, and that task is run again like the others.
    results = []
    for result in run_tasks(_square_or_die_late, range(8), workers=2,
                            crashed=lambda n: f"died {n}"):
        if not results:
            time.sleep(1.0)
        results.append(result)
    assert sorted(results, key=str) == sorted(["died 0", 1, 4, 9, 16, 25, 36, 49], key=str)


def test_tasks_are_read_only_as_places_free_up():
    taken: list[int] = []

    def tasks():
        for number in range(100):
            taken.append(number)
            yield number

    results = run_tasks(_square, tasks(), workers=2, crashed=repr)
    first = next(results)
    assert first in {n * n for n in taken}
    assert len(taken) <= 2 * 2 + 1  # the window of 2 * workers, plus the one that ended it
    results.close()


def test_workers_must_be_positive():
    with pytest.raises(InputError, match="workers: must be at least 1"):
        list(run_tasks(_square, [1], workers=0, crashed=repr))


@pytest.mark.parametrize(
    ("address", "expected"),
    [
        pytest.param("tcp://127.0.0.1:8786", "tcp://127.0.0.1:8786", id="tcp"),
        pytest.param(" scheduler:8786 ", "scheduler:8786", id="bare-host-port"),
        pytest.param("tls://[::1]:8786", "tls://[::1]:8786", id="ipv6"),
    ],
)
def test_scheduler_addresses_are_accepted(address, expected):
    assert check_scheduler_address(address) == expected


@pytest.mark.parametrize(
    ("address", "message"),
    [
        pytest.param("", "scheduler: expected an address", id="empty"),
        pytest.param(8786, "scheduler: expected an address", id="int"),
        pytest.param("http://127.0.0.1:8787", "is not a Dask scheduler address", id="dashboard"),
        pytest.param("localhost", "is not a Dask scheduler address", id="no-port"),
    ],
)
def test_other_addresses_are_bad_input(address, message):
    with pytest.raises(InputError, match=message):
        check_scheduler_address(address)


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc thresholds")
def test_a_dask_worker_reuses_the_heap_for_large_arrays():
    require_package("distributed")
    from distributed import LocalCluster

    n_arrays, pages = 20, 2**20 // os.sysconf("SC_PAGE_SIZE")
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=DASK_DASHBOARD) as cluster:
        [(trim, faults)] = run_on_cluster(_page_faults_of_arrays, [n_arrays],
                                          address=cluster.scheduler_address,
                                          failed=lambda task, error: (None, -1),
                                          name=lambda task: "faults")
    assert trim == "65536"  # Dask's default, which alone would fault every array's pages in
    # Freshly mapped arrays would fault n_arrays * pages; from the reused heap they fault
    # nothing, or one array's pages where the allocator grows the heap once more.
    assert 0 <= faults < n_arrays * pages // 4
