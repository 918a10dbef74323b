"""numba, imported once with the package's choice of threading layer.

Import numba through this module (``from vptoolkit._numba import numba``)
wherever the package may be the first to use its threads: numba picks its
threading layer when threads are first used, and by default tries TBB first;
pymeshlab ships an old TBB that numba would then warn about and reject.
OpenMP comes first here, unless the user chose with ``NUMBA_THREADING_LAYER``
or ``NUMBA_THREADING_LAYER_PRIORITY``.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator

import numba

__all__ = ["numba", "threads", "max_threads"]

if "NUMBA_THREADING_LAYER" not in os.environ and "NUMBA_THREADING_LAYER_PRIORITY" not in os.environ:
    # numba.config sets its options at run time, out of the stubs' sight
    numba.config.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]  # type: ignore[attr-defined]


def will_compile(dispatcher: object) -> bool:
    """Whether the next call of a ``cache=True`` function compiles it (no usable cache).

    True only when the function is not compiled in this process and numba's
    on-disk index for it is missing or stale (its source file changed), the
    cases where numba compiles instead of loading. Any doubt (another numba
    version's internals, an unreadable index) answers False, so a message
    built on it is never shown for a load from the cache.
    """
    try:
        if dispatcher.signatures:  # type: ignore[attr-defined]
            return False
        index = dispatcher._cache._cache_file._load_index()  # type: ignore[attr-defined]
    except Exception:  # noqa: BLE001 - numba internals; silence is the safe answer
        return False
    return not index


@contextlib.contextmanager
def threads(n: int) -> Iterator[None]:
    """numba's thread count for the calling thread set to ``n`` inside the block, then restored.

    A build's worker process runs numba with one thread; code in the calling
    process that should cost what a worker's share costs (a dry run's
    calibration) runs inside ``threads(1)``.
    """
    previous = numba.get_num_threads()
    numba.set_num_threads(min(n, max_threads()))
    try:
        yield
    finally:
        numba.set_num_threads(previous)


def max_threads() -> int:
    """The most threads numba may use in this process (``NUMBA_NUM_THREADS``)."""
    return int(numba.config.NUMBA_NUM_THREADS)  # type: ignore[attr-defined]
