"""Benchmark of :func:`vptoolkit.dataset.build.build_dataset`: models per hour and bytes per model.

Makes a ModelNet-style tree from the bundled sample meshes (every sample,
``--copies`` times under new names, spread over three categories and
``train/`` and ``test/``) and builds it from scratch once per worker count.
For each build it prints the wall-clock seconds, the models per hour and the
speed-up over the first worker count of the same run (the baseline), then
the bytes per model of the Zarr store, of the same data written as HDF5 and
of the staging folder the build keeps for resuming. Under each build it prints
the seconds per model of each stage (load, clean, sample, measure, write;
``BuildResult.stage_seconds``) and its share of the time.

Default sizes are the paper's: 1000 views at 1024 px, 20000 points, cleaning
on with at most 10000 faces. ``--quick`` uses 100 views at 128 px, 2000
points and at most 2000 faces. The times include starting the worker
processes and loading numba's cached kernels in each of them.

Usage::

    python tools/bench_build.py --quick
    python tools/bench_build.py                     # full sizes, a few minutes
    python tools/bench_build.py --copies 4 --workers 1 2 --json results.json
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vptoolkit.dataset.build import STAGING_DIR, build_dataset
from vptoolkit.dataset.store import ModelEntry, StoreReader, open_store, write_dataset
from vptoolkit.samples import sample_names, sample_path

FULL = {"n_views": 1000, "resolution": 1024, "n_points": 20000, "max_faces": 10000}
QUICK = {"n_views": 100, "resolution": 128, "n_points": 2000, "max_faces": 2000}
CATEGORIES = ("alpha", "beta", "gamma")


def make_tree(root: Path, copies: int) -> int:
    """Copy every sample mesh ``copies`` times into a ModelNet-style tree; return the file count."""
    n_files = 0
    for index, name in enumerate(sample_names()):
        source = sample_path(name)
        for copy in range(copies):
            number = index * copies + copy
            folder = root / CATEGORIES[number % len(CATEGORIES)] / ("test" if number % 5 == 4 else "train")
            folder.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, folder / f"{source.stem.lower()}_{copy:03d}{source.suffix}")
            n_files += 1
    return n_files


def folder_bytes(path: Path) -> int:
    """Bytes of a file, or of every file under a folder."""
    if path.is_file():
        return path.stat().st_size
    return sum(item.stat().st_size for item in path.rglob("*") if item.is_file())


class _Entries(Sequence[ModelEntry]):
    """The models of an open store as a lazy sequence, to write them again elsewhere."""

    def __init__(self, reader: StoreReader) -> None:
        self._reader = reader

    def __len__(self) -> int:
        return self._reader.n_models

    def __getitem__(self, index: Any) -> Any:
        return self._reader.entry(index)


def hdf5_bytes(zarr_store: Path, target: Path) -> int:
    """Write the models of a Zarr store to an HDF5 file and return its size."""
    with open_store(zarr_store) as reader:
        write_dataset(
            target,
            _Entries(reader),
            attrs=reader.attrs,
            views=reader.array("views")[...],
            failures=reader.failures(),
        )
    return target.stat().st_size


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="small sizes (seconds, not minutes)")
    parser.add_argument("--copies", type=int, default=1, help="copies of each sample (default: 1)")
    parser.add_argument(
        "--workers", type=int, nargs="+", default=[1, 2],
        help="worker counts to time; the first is the baseline (default: 1 2)",
    )
    parser.add_argument("--no-clean", action="store_true", help="skip mesh cleaning")
    parser.add_argument("--json", type=Path, help="also write the results to this JSON file")
    args = parser.parse_args(argv)
    sizes = dict(QUICK if args.quick else FULL)

    with tempfile.TemporaryDirectory(prefix="bench_build_") as scratch:
        root = Path(scratch)
        n_files = make_tree(root / "samples", args.copies)
        print(
            f"{n_files} files from {len(sample_names())} sample meshes; {sizes['n_views']} views at "
            f"{sizes['resolution']} px, {sizes['n_points']} points, "
            + ("no cleaning" if args.no_clean else f"cleaning to <= {sizes['max_faces']} faces")
        )
        print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start "
              "(times are only comparable on an otherwise idle machine)")
        header = f"{'workers':>7} {'models':>6} {'failed':>6} {'seconds':>8} {'models/hour':>12} {'speed-up':>9}"
        print(header)
        print("-" * len(header))
        runs: list[dict[str, Any]] = []
        for workers in args.workers:
            out = root / f"out_{workers}"
            started = time.perf_counter()
            result = build_dataset(root / "samples", out, workers=workers, clean=not args.no_clean, **sizes)
            seconds = time.perf_counter() - started
            per_hour = 3600.0 * result.n_models / seconds
            speed_up = runs[0]["seconds"] / seconds if runs else 1.0
            load = os.getloadavg()[0]
            runs.append({"workers": workers, "n_models": result.n_models,
                         "n_failures": result.n_failures, "seconds": seconds,
                         "models_per_hour": per_hour, "speed_up": speed_up, "load_average": load})
            print(f"{workers:>7} {result.n_models:>6} {result.n_failures:>6} {seconds:>8.1f} "
                  f"{per_hour:>12.0f} {speed_up:>8.2f}x  load {load:.1f}", flush=True)
            runs[-1]["stage_seconds"] = dict(result.stage_seconds)
            total = sum(result.stage_seconds.values()) or 1.0
            per_model = max(1, result.n_computed)
            print("        per model: " + ", ".join(
                f"{stage} {spent / per_model:.2f} s ({100 * spent / total:.0f} %)"
                for stage, spent in result.stage_seconds.items()
            ))
            for failure in result.failures:
                print(f"        failed: {failure['reason']}")

        out = root / f"out_{args.workers[0]}"
        n_models = max(1, runs[0]["n_models"])
        sizes_per_model = {
            "zarr": folder_bytes(out / "dataset.zarr") / n_models,
            "hdf5": hdf5_bytes(out / "dataset.zarr", root / "dataset.h5") / n_models,
            "staging": folder_bytes(out / STAGING_DIR) / n_models,
        }
        print("\nbytes per model: " + ", ".join(
            f"{kind} {value / 1024:.0f} KiB" for kind, value in sizes_per_model.items()
        ))
        print("(staging: the .staging folder a build keeps for resuming and incremental rebuilds)")
    if args.json:
        args.json.write_text(json.dumps(
            {"sizes": sizes, "clean": not args.no_clean, "n_files": n_files, "runs": runs,
             "bytes_per_model": sizes_per_model}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
