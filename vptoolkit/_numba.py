"""numba, imported once with the package's choice of threading layer.

Import numba through this module (``from vptoolkit._numba import numba``)
wherever the package may be the first to use its threads: numba picks its
threading layer when threads are first used, and by default tries TBB first;
pymeshlab ships an old TBB that numba would then warn about and reject.
OpenMP comes first here, unless the user chose with ``NUMBA_THREADING_LAYER``
or ``NUMBA_THREADING_LAYER_PRIORITY``.
"""

from __future__ import annotations

import os

import numba

__all__ = ["numba"]

if "NUMBA_THREADING_LAYER" not in os.environ and "NUMBA_THREADING_LAYER_PRIORITY" not in os.environ:
    numba.config.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]
