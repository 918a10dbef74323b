"""Peak memory and time of ``vptool best-view`` on a large point cloud file.

For each count N of ``--points`` the tool draws N area-uniform points of a
bundled sample with their normals (:func:`vptoolkit.points.sample_surface`,
seed 0), writes them as an ``(N, 6)`` float32 ``.npy`` (x y z nx ny nz, the
points-only format :mod:`vptoolkit.io.point_files` reads), and runs
``vptool best-view FILE --json`` on it in a fresh process: the default
search (64 views at 128 px, the paper's four), the file read as the command
reads it (:func:`vptoolkit.io.load`, whose ``max_points``,
:data:`vptoolkit.point_cloud.MAX_POINTS`, thins a larger cloud by
:func:`vptoolkit.point_cloud.voxel_subset` before anything else is made of
it). Reported per N: the file's size, the process's peak resident memory
(``ru_maxrss`` of that child alone, :func:`os.wait4`), its wall time, and the
search's own seconds from the command's JSON.

Usage::

    python tools/bench_cloud_memory.py --points 20000              # a smoke test, seconds
    python tools/bench_cloud_memory.py --results docs/benchmarks.md  # 10^6 and 10^7 points
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from results_doc import add_results_option, command_line, machine, write_section

from vptoolkit.io import load_mesh
from vptoolkit.point_cloud import MAX_POINTS
from vptoolkit.points import sample_surface
from vptoolkit.samples import sample_path

CHUNK = 1_000_000  # points drawn per call while writing, so the writer stays small


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", default="1000000,10000000",
                        help="point counts, separated by commas (default: 1000000,10000000)")
    parser.add_argument("--sample", default="bunny", help="the bundled sample drawn (default: "
                                                          "bunny)")
    parser.add_argument("--work", type=Path,
                        help="where the cloud files are written (default: a temporary folder, "
                             "removed afterwards)")
    add_results_option(parser, "cloud_memory")
    args = parser.parse_args(argv)
    try:
        args.counts = [int(count) for count in args.points.split(",")]
    except ValueError:
        parser.error("--points: expected integers separated by commas")
    if not args.counts or min(args.counts) < 3:
        parser.error("--points: every count must be at least 3")
    if args.work is not None and args.work.exists() and not args.work.is_dir():
        parser.error(f"--work: {args.work} is not a folder")
    return args


def write_cloud(path: Path, sample: str, n_points: int) -> None:
    """``n_points`` area-uniform points of ``sample`` and their normals, an (N, 6) float32 .npy.

    Drawn in chunks of :data:`CHUNK` points (seeds 0, 1, ...) into a
    memory-mapped file, so the writer never holds the cloud in float64.
    """
    mesh = load_mesh(sample_path(sample))
    table = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32, shape=(n_points, 6))
    for seed, start in enumerate(range(0, n_points, CHUNK)):
        drawn = sample_surface(mesh, min(CHUNK, n_points - start), seed=seed)
        table[start:start + len(drawn.points)] = np.hstack([drawn.points, drawn.normals])
    table.flush()
    del table


def measure(path: Path) -> tuple[float, float, float]:
    """Run ``vptool best-view PATH --json`` in a fresh process.

    Returns
    -------
    peak_mib : float
        The process's peak resident memory, MiB.
    wall_s, search_s : float
        Its wall seconds, and the search's own (the command's JSON).
    """
    command = [sys.executable, "-c", "from vptoolkit.cli import main; main()",
               "best-view", str(path), "--json"]
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        started = time.perf_counter()
        process = subprocess.Popen(command, stdout=out, stderr=err)
        _, status, usage = os.wait4(process.pid, 0)  # this child's own usage
        wall = time.perf_counter() - started
        process.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        if process.returncode != 0:
            raise RuntimeError(f"vptool best-view {path.name} failed: "
                               f"{err.read().decode()[-2000:]}")
        search = json.loads(out.read())["results"][0]["seconds"]
    return usage.ru_maxrss / 1024.0, wall, float(search)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    lines = [f"Command: `{command_line(__file__, argv)}`; {machine()}. `vptool best-view "
             f"FILE --json` (the default search) in a fresh process on N area-uniform points "
             f"of the {args.sample} with normals, an (N, 6) float32 `.npy`; clouds above "
             f"max_points = {MAX_POINTS:,} are thinned on reading:", "",
             "| points | file MiB | peak resident MiB | wall s | search s |",
             "|---:|---:|---:|---:|---:|"]
    with tempfile.TemporaryDirectory() as temporary:
        folder = args.work or Path(temporary)
        folder.mkdir(parents=True, exist_ok=True)
        for count in args.counts:
            path = folder / f"{args.sample}_{count}.npy"
            write_cloud(path, args.sample, count)
            peak, wall, search = measure(path)
            lines.append(f"| {count:,} | {path.stat().st_size / 2**20:.1f} | {peak:.0f} | "
                         f"{wall:.1f} | {search:.1f} |")
            print(lines[-1], file=sys.stderr, flush=True)  # as it goes; the table at the end
            if args.work is None:
                path.unlink()
    text = "\n".join(lines)
    print(text)
    if args.results is not None:
        write_section(args.results, args.section, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
