"""Benchmark of :func:`vptoolkit.dataset.builder.run.build_dataset`: models per hour and bytes
per model.

Makes a ModelNet-style tree from the bundled sample meshes (every sample,
``--copies`` times under new names, spread over three categories and
``train/`` and ``test/``) and builds it from scratch once per worker count.
For each build it prints the wall-clock seconds, the CPU seconds (user and
system, of all threads; one worker only, since pool workers are children of
multiprocessing's fork server, not of this process), the models per hour and
the speed-up over the first worker count of the same run (the baseline), then
the bytes per model of the Zarr store, of the same data written as HDF5 and
of the staging folder the build keeps for resuming. Under each build it prints
the seconds per model of each stage (load, clean, sample, measure, write;
``BuildResult.stage_seconds``) and its share of the time.

``--meshes DIR`` builds the mesh files under DIR instead of the samples, e.g.
raw ModelNet models, whose cleaning costs far more than the samples'.

Default sizes are the paper's: 1000 views at 1024 px, 20000 points, cleaning
on with at most 10000 faces. ``--quick`` uses 100 views at 128 px, 2000
points and at most 2000 faces. The times include starting the worker
processes and loading numba's cached kernels in each of them.

``--baseline DIR`` compares against other code in the same run: DIR is a
checkout of an older vptoolkit (``git worktree add DIR REV``). Each build is
then preceded by the same build with that code, in a child process run in
DIR with ``PYTHONPATH`` DIR (timed around ``build_dataset`` only, as here), and the
speed-up column is this code's models per hour over the baseline's with the
same workers. Both codes first build one small model untimed, so that numba's
kernels are compiled and cached. ``--rounds N`` repeats the alternation and
keeps each code's fastest build, which damps the noise of a shared machine.
On a busy machine CPU seconds per model (``--workers 1``) vary far less than
wall-clock time: they are the fairer comparison there.

Usage::

    python tools/bench_build.py --quick
    python tools/bench_build.py                     # full sizes, a few minutes
    python tools/bench_build.py --copies 4 --workers 1 2 --json results.json
    python tools/bench_build.py --workers 2 --baseline /tmp/base --rounds 2
    python tools/bench_build.py --meshes ~/modelnet/airplane --baseline /tmp/base
    python tools/bench_build.py --results docs/benchmarks.md            # and its section ``build``
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from results_doc import add_results_option, printed_section

from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.builder.run import BuildResult, build_dataset
from vptoolkit.dataset.builder.staging import STAGING_DIR
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.dataset.store.writer import write_dataset
from vptoolkit.io import find_mesh_files
from vptoolkit.samples import sample_names, sample_path
from vptoolkit.settings import MeasureSettings

FULL = {"n_views": 1000, "resolution": 1024, "n_points": 20000, "max_faces": 10000}
QUICK = {"n_views": 100, "resolution": 128, "n_points": 2000, "max_faces": 2000}
CATEGORIES = ("alpha", "beta", "gamma")


def mesh_sources(folder: Path | None) -> list[Path]:
    """The meshes to build: every sample, or every mesh file under ``folder`` (sorted)."""
    if folder is None:
        return [sample_path(name) for name in sample_names()]
    return find_mesh_files(folder)


def make_tree(root: Path, copies: int, sources: Sequence[Path]) -> int:
    """Copy every mesh ``copies`` times into a ModelNet-style tree; return the file count."""
    n_files = 0
    for index, source in enumerate(sources):
        for copy in range(copies):
            number = index * copies + copy
            folder = (root / CATEGORIES[number % len(CATEGORIES)]
                      / ("test" if number % 5 == 4 else "train"))
            folder.mkdir(parents=True, exist_ok=True)
            # ``number`` is unique, so meshes of the same name in different folders stay apart.
            shutil.copyfile(source, folder / f"{source.stem.lower()}_{number:03d}{source.suffix}")
            n_files += 1
    return n_files


def build_with(src: Path, out: Path, options: dict[str, Any]) -> BuildResult:
    """``build_dataset`` with the bench's flat options (sizes, ``clean`` and ``workers``)."""
    rest = dict(options)
    workers = rest.pop("workers")
    measure = MeasureSettings(views=rest.pop("n_views"), resolution=rest.pop("resolution"))
    return build_dataset(src, out, BuildOptions(measure, **rest), workers=workers)


def cpu_seconds() -> float:
    """User and system seconds of this process (all its threads) and of its waited-for children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


_CHILD_BUILD = """
import json, resource, sys, time
import vptoolkit
from vptoolkit.dataset.builder.run import build_dataset
def cpu_seconds():
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime
options = json.loads(sys.argv[3])
started, cpu_started = time.perf_counter(), cpu_seconds()
try:
    from vptoolkit.dataset.builder.options import BuildOptions
    from vptoolkit.settings import MeasureSettings
except ImportError:  # a baseline whose build_dataset takes the options as keywords
    result = build_dataset(sys.argv[1], sys.argv[2], **options)
else:
    workers = options.pop("workers")
    measure = MeasureSettings(views=options.pop("n_views"), resolution=options.pop("resolution"))
    result = build_dataset(sys.argv[1], sys.argv[2], BuildOptions(measure, **options),
                           workers=workers)
seconds, cpu = time.perf_counter() - started, cpu_seconds() - cpu_started
print(json.dumps({"seconds": seconds, "cpu_seconds": cpu, "n_models": result.n_models,
                  "n_failures": result.n_failures, "code": vptoolkit.__file__,
                  "stage_seconds": dict(getattr(result, "stage_seconds", {})),
                  "n_computed": getattr(result, "n_computed", result.n_models)}))
"""


def baseline_build(code: Path, src: Path, out: Path, options: dict[str, Any]) -> dict[str, Any]:
    """Build ``src`` into ``out`` with the vptoolkit checked out at ``code``, in a child process.

    Returns the child's record: ``seconds`` (around ``build_dataset`` only),
    ``cpu_seconds`` (the same span, see :func:`cpu_seconds`), ``n_models``,
    ``n_failures``, ``code`` (the imported package's path), and
    ``stage_seconds`` and ``n_computed`` (empty and ``n_models`` for code
    older than the per-stage timings).
    """
    env = {**os.environ, "PYTHONPATH": str(code)}
    done = subprocess.run(
        [sys.executable, "-c", _CHILD_BUILD, str(src), str(out), json.dumps(options)],
        env=env, cwd=code, capture_output=True, text=True, check=False,
    )
    if done.returncode != 0:
        raise SystemExit(f"bench_build: the baseline build failed:\n{done.stderr.strip()}")
    record: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    if not Path(record["code"]).resolve().is_relative_to(code.resolve()):
        raise SystemExit(f"bench_build: the baseline child imported {record['code']}, not {code}")
    return record


def warm_up(root: Path, code: Path | None, sizes: dict[str, Any], clean: bool) -> None:
    """Build one small sample untimed, so that numba's kernels are compiled and cached."""
    src = root / "warm_up_src"
    (src / "alpha" / "train").mkdir(parents=True, exist_ok=True)
    shutil.copyfile(sample_path("bottle"), src / "alpha" / "train" / "bottle.obj")
    options = {**sizes, "n_views": 8, "workers": 1, "clean": clean}
    out = root / f"warm_up_{'baseline' if code else 'this'}"
    if code is None:
        build_with(src, out, options)
    else:
        baseline_build(code, src, out, options)
    shutil.rmtree(out)


def folder_bytes(path: Path) -> int:
    """Bytes of a file, or of every file under a folder."""
    if path.is_file():
        return path.stat().st_size
    return sum(item.stat().st_size for item in path.rglob("*") if item.is_file())


def hdf5_bytes(zarr_store: Path, target: Path) -> int:
    """Write the models of a Zarr store to an HDF5 file and return its size."""
    with open_store(zarr_store) as reader:
        write_dataset(
            target,
            reader.entries(),
            attrs=reader.attrs,
            views=reader.array("views")[...],
            failures=reader.failures(),
        )
    return target.stat().st_size


def _cpu_cell(cpu: float, workers: int) -> str:
    """CPU seconds, shown for one worker only: pool workers are not this process's children."""
    return f"{cpu:>7.1f}" if workers == 1 else f"{'-':>7}"


def _print_stages(stage_seconds: dict[str, float], n_computed: int) -> None:
    """One line: seconds per model of each stage and its share (nothing if not recorded)."""
    if not stage_seconds:
        return
    total = sum(stage_seconds.values()) or 1.0
    per_model = max(1, n_computed)
    print("        per model: " + ", ".join(
        f"{stage} {spent / per_model:.2f} s ({100 * spent / total:.0f} %)"
        for stage, spent in stage_seconds.items()
    ))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="small sizes (seconds, not minutes)")
    parser.add_argument("--copies", type=int, default=1, help="copies of each sample (default: 1)")
    parser.add_argument(
        "--workers", type=int, nargs="+", default=[1, 2],
        help="worker counts to time; the first is the baseline (default: 1 2)",
    )
    parser.add_argument(
        "--meshes", type=Path,
        help="build the mesh files under this folder instead of the bundled samples",
    )
    parser.add_argument("--no-clean", action="store_true", help="skip mesh cleaning")
    parser.add_argument("--json", type=Path, help="also write the results to this JSON file")
    parser.add_argument(
        "--baseline", type=Path,
        help="a checkout of older vptoolkit code to time before each build (see above)",
    )
    parser.add_argument(
        "--rounds", type=int, default=1,
        help="times to repeat the builds; each code's fastest counts (default: 1)",
    )
    add_results_option(parser, "build")
    args = parser.parse_args(argv)
    sizes = dict(QUICK if args.quick else FULL)
    clean = not args.no_clean
    if args.meshes is not None and not args.meshes.is_dir():
        parser.error(f"--meshes: {args.meshes} is not a folder")
    sources = mesh_sources(args.meshes)
    if not sources:
        parser.error(f"--meshes: no mesh file under {args.meshes}")
    if args.baseline is not None and not (args.baseline / "vptoolkit" / "__init__.py").is_file():
        parser.error(f"--baseline: {args.baseline} holds no vptoolkit package")

    with printed_section(args.results, args.section):
        with tempfile.TemporaryDirectory(prefix="bench_build_") as scratch:
            root = Path(scratch)
            n_files = make_tree(root / "samples", args.copies, sources)
            what = "sample meshes" if args.meshes is None else f"meshes under {args.meshes}"
            print(
                f"{n_files} files from {len(sources)} {what}; {sizes['n_views']} views at "
                f"{sizes['resolution']} px, {sizes['n_points']} points, "
                + ("no cleaning" if args.no_clean else f"cleaning to <= {sizes['max_faces']} faces")
            )
            print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start "
                  "(times are only comparable on an otherwise idle machine)")
            if args.baseline is not None:
                print(f"baseline: the code in {args.baseline}, "
                      "built before each build of this code")
                warm_up(root, args.baseline, sizes, clean)
                warm_up(root, None, sizes, clean)
            header = (f"{'code':>8} {'workers':>7} {'models':>6} {'failed':>6} {'seconds':>8} "
                      f"{'cpu s':>7} {'models/hour':>12} {'speed-up':>9}")
            print(header)
            print("-" * len(header))
            runs: list[dict[str, Any]] = []
            baselines: list[dict[str, Any]] = []
            for round_index in range(args.rounds):
                for workers in args.workers:
                    options = {**sizes, "workers": workers, "clean": clean}
                    suffix = f"{workers}_{round_index}"
                    baseline = None
                    if args.baseline is not None:
                        baseline = baseline_build(
                            args.baseline, root / "samples", root / f"base_{suffix}", options)
                        shutil.rmtree(root / f"base_{suffix}")
                        baseline.update(workers=workers, round=round_index,
                                        models_per_hour=(3600.0 * baseline["n_models"]
                                                         / baseline["seconds"]),
                                        load_average=os.getloadavg()[0])
                        baselines.append(baseline)
                        print(f"{'baseline':>8} {workers:>7} {baseline['n_models']:>6} "
                              f"{baseline['n_failures']:>6} {baseline['seconds']:>8.1f} "
                              f"{_cpu_cell(baseline['cpu_seconds'], workers)} "
                              f"{baseline['models_per_hour']:>12.0f} {'':>9}  "
                              f"load {baseline['load_average']:.1f}", flush=True)
                        _print_stages(baseline["stage_seconds"], baseline["n_computed"])
                    out = root / f"out_{suffix}"
                    started, cpu_started = time.perf_counter(), cpu_seconds()
                    result = build_with(root / "samples", out, options)
                    seconds, cpu = time.perf_counter() - started, cpu_seconds() - cpu_started
                    per_hour = 3600.0 * result.n_models / seconds
                    if baseline is not None:
                        speed_up = baseline["seconds"] / seconds
                    else:
                        speed_up = runs[0]["seconds"] / seconds if runs else 1.0
                    load = os.getloadavg()[0]
                    runs.append({"workers": workers, "round": round_index,
                                 "n_models": result.n_models,
                                 "n_failures": result.n_failures, "seconds": seconds,
                                 "cpu_seconds": cpu,
                                 "models_per_hour": per_hour, "speed_up": speed_up,
                                 "load_average": load})
                    print(f"{'this':>8} {workers:>7} {result.n_models:>6} {result.n_failures:>6} "
                          f"{seconds:>8.1f} {_cpu_cell(cpu, workers)} {per_hour:>12.0f} "
                          f"{speed_up:>8.2f}x  load {load:.1f}", flush=True)
                    runs[-1]["stage_seconds"] = dict(result.stage_seconds)
                    _print_stages(result.stage_seconds, result.n_computed)
                    for failure in result.failures:
                        print(f"        failed: {failure['reason']}")
            if args.rounds > 1 or baselines:
                print("\nfastest per code and workers:")
                for workers in args.workers:
                    best = min((run for run in runs if run["workers"] == workers),
                               key=lambda run: run["seconds"])
                    line = f"  {workers} workers: this {best['models_per_hour']:.0f} models/hour"
                    if baselines:
                        base = min((run for run in baselines if run["workers"] == workers),
                                   key=lambda run: run["seconds"])
                        line += (f", baseline {base['models_per_hour']:.0f}: "
                                 f"{base['seconds'] / best['seconds']:.2f}x")
                        if workers == 1:
                            this_cpu = min(run["cpu_seconds"] for run in runs
                                           if run["workers"] == 1)
                            base_cpu = min(run["cpu_seconds"] for run in baselines
                                           if run["workers"] == 1)
                            line += (f"; CPU seconds per model "
                                     f"{base_cpu / best['n_models']:.2f} -> "
                                     f"{this_cpu / best['n_models']:.2f}: "
                                     f"{base_cpu / this_cpu:.2f}x")
                    print(line)

            out = root / f"out_{args.workers[0]}_0"
            n_models = max(1, runs[0]["n_models"])
            sizes_per_model = {
                "zarr": folder_bytes(out / "dataset.zarr") / n_models,
                "hdf5": hdf5_bytes(out / "dataset.zarr", root / "dataset.h5") / n_models,
                "staging": folder_bytes(out / STAGING_DIR) / n_models,
            }
            print("\nbytes per model: " + ", ".join(
                f"{kind} {value / 1024:.0f} KiB" for kind, value in sizes_per_model.items()
            ))
            print("(staging: the .staging folder a build keeps for resuming "
                  "and incremental rebuilds)")
        if args.json:
            args.json.write_text(json.dumps(
                {"sizes": sizes, "clean": clean, "n_files": n_files, "runs": runs,
                 "baseline": str(args.baseline) if args.baseline else None,
                 "baseline_runs": baselines, "bytes_per_model": sizes_per_model}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
