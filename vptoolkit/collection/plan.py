"""How big a collection run is, before it runs: files, hours and disk.

:func:`plan_collection` streams the entries of a source once (counting
them and their bytes, never holding the list), answers the first few in this
process (:func:`vptoolkit.collection.runner.answer_entry`, numba's one-time
kernel load drawn first so that no entry's time holds it) and scales:
``seconds = n_files * mean seconds per sampled file / workers`` (a Dask
cluster's size is not known here: ``workers`` is what the caller says), and
the disk of the staged records and the table from the sampled records'
size, plus ``extra_bytes_per_file`` (a thumbnail's picture). Nothing is
written.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from vptoolkit.checks import check_int
from vptoolkit.collection.discover import discover, is_remote_entry
from vptoolkit.collection.methods import Method
from vptoolkit.collection.runner import MAX_MODEL_FACES, TIMEOUT_S, EntryTask, answer_entry
from vptoolkit.files import json_text
from vptoolkit.point_cloud import MAX_POINTS

__all__ = ["CollectionPlan", "plan_collection", "SAMPLED_FILES"]

SAMPLED_FILES = 3
"""Files a plan answers to time the rest."""

_TABLE_SHARE = 0.5  # table bytes per staged-record byte (zstd over JSON), roughly


@dataclass(frozen=True)
class CollectionPlan:
    """The size of a collection run.

    Attributes
    ----------
    n_files : int
        Entries of the source.
    n_bytes : int
        Their size on disk (local files only).
    n_sampled : int
        Entries answered for the estimate.
    seconds : float
        Estimated wall time of the whole run.
    disk_bytes : int
        Estimated disk of the run's output.
    """

    n_files: int
    n_bytes: int
    n_sampled: int
    seconds: float
    disk_bytes: int

    def lines(self) -> list[str]:
        """What ``--dry-run`` prints."""
        if not self.n_sampled:
            return [f"{self.n_files} files ({_size(self.n_bytes)}); none answered to estimate "
                    "time and disk"]
        return [f"{self.n_files} files ({_size(self.n_bytes)})",
                f"estimate from {self.n_sampled} files: {_duration(self.seconds)}, "
                f"{_size(self.disk_bytes)} of output"]


def _size(n_bytes: float) -> str:
    return f"{n_bytes / 1e6:.1f} MB" if n_bytes >= 1e5 else f"{n_bytes / 1e3:.1f} kB"


def _duration(seconds: float) -> str:
    if seconds >= 3600:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 60:.1f} min" if seconds >= 60 else f"{seconds:.1f} s"


def plan_collection(source: str | os.PathLike[str], method: Method, *, workers: int = 1,
                    sampled: int = SAMPLED_FILES, extra_bytes_per_file: int = 0,
                    max_faces: int = MAX_MODEL_FACES, timeout: float = TIMEOUT_S,
                    max_points: int = MAX_POINTS) -> CollectionPlan:
    """Count ``source`` and estimate the time and disk of running ``method`` over it.

    Parameters
    ----------
    source : str or path-like
        As :func:`vptoolkit.collection.discover.discover` takes it.
    method : Method
        What the run computes.
    workers : int
        Processes (or cluster threads) the run will use (default: 1).
    sampled : int
        Files answered to time (default: :data:`SAMPLED_FILES`; 0 counts only).
    extra_bytes_per_file : int
        Output beyond the staged record and the table row, e.g. a picture.
    max_faces, timeout, max_points
        As :func:`vptoolkit.collection.runner.run_collection` takes them.
    """
    from vptoolkit.best_view.run import load_kernels

    workers = check_int(workers, "workers", minimum=1)
    sampled = check_int(sampled, "sampled", minimum=0)
    n_files = n_bytes = 0
    seconds: list[float] = []
    record_bytes: list[int] = []
    for entry in discover(source):
        n_files += 1
        if not is_remote_entry(entry.path):
            try:
                n_bytes += os.stat(entry.path).st_size
            except OSError:
                pass
        if len(seconds) < sampled:
            if not seconds:
                load_kernels()
            result = answer_entry(EntryTask(entry, "", method, max_faces, timeout, max_points))
            if result.answer is not None:
                seconds.append(result.seconds)
                record_bytes.append(len(json_text(result.record(), indent=None)))
    per_file = sum(seconds) / len(seconds) if seconds else 0.0
    per_record = sum(record_bytes) / len(record_bytes) if record_bytes else 0.0
    disk = n_files * (per_record * (1 + _TABLE_SHARE) + extra_bytes_per_file)
    return CollectionPlan(n_files, n_bytes, len(seconds), n_files * per_file / workers,
                          int(disk))
