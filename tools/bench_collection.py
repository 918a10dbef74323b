"""Benchmark: a collection run of ``vptool best-view`` and ``vptool thumbnails`` at scale.

A collection of ``--files`` model files is built in a temporary folder by
hard-linking (or copying) real, licensed meshes many times over: the
gazebo_models and object_sim folders of ``--meshes`` (see its README) and
the bundled samples (``vptoolkit/samples``), in turn, as
``NNN/NNNNN_<name>``. Both commands run at their default settings, each as
its own ``vptool`` process (what a user starts), and the bench prints:

* files per hour with 1 and 2 local worker processes and with a Dask
  ``LocalCluster`` of 2 worker processes of 1 thread each
  (``--scheduler``); ``thumbnails`` runs over the first
  ``--thumbnail-files`` files (the software engine draws in the workers);
* where a file's time goes, summed over the run from ``timings.jsonl``:
  read (load the file), answer (the search), draw (draw the thumbnail and
  encode its PNG), all three in the worker, finish (write the thumbnail, in
  the calling process) and stage (write the entry's record);
* peak resident memory of the calling process and of its workers together
  (sampled every 0.2 s with psutil; a Dask cluster's worker and nanny
  processes count as workers);
* the runner's overhead, ``wall / (sum of per-file seconds / workers) - 1``
  (target: at most 10 %; the wall time includes starting Python, importing
  and numba's kernel load in every process, which the per-file seconds of a
  worker's first file hold too);
* Dask over 2 local processes, files per hour (target: within 10 %);
* thumbnails at their default (the search) over the old default (every one
  of 1000 views measured at 1024 px, ``--views 1000 --resolution 1024``),
  the median seconds per file over the same ``--old-files`` files
  (target: at least 5x);
* ``kill -9``: ``best-view`` with 2 workers is killed once a third of the
  files are staged, then run again; the rerun must answer exactly the files
  not staged (at most the files in flight are lost) and write a table with
  the same bytes as an uninterrupted run;
* memory over a list of ``--list-lines`` (default 10^6) lines naming a few
  small sample files: ``--dry-run`` streams the whole list (count and
  size), and a full run answers its first ``--list-run`` lines (each file
  answered once, the repeats found staged); resident memory is sampled over
  both and must stay flat.

Usage::

    nice -n 10 python tools/bench_collection.py --files 1000 --results docs/benchmarks.md
    python tools/bench_collection.py --quick    # the samples only, a few files (a smoke test)
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from results_doc import add_results_option, format_seconds, printed_section

from vptoolkit.collection.discover import is_model_file
from vptoolkit.samples import sample_path

MESH_FOLDERS = ("gazebo_models", "object_sim")
SMALL_SAMPLES = ("table.obj", "ballA.off", "teapot.stl", "angle_block.STL")
STAGES = ("read", "answer", "draw", "finish", "stage")
SAMPLE_EVERY_S = 0.2
VPTOOL = ("-c", "from vptoolkit.cli import main; main()")


def mesh_pool(meshes: Path | None) -> list[Path]:
    """The real meshes a collection repeats: ``meshes``' licensed folders and the samples."""
    folders = [meshes / name for name in MESH_FOLDERS] if meshes is not None else []
    folders.append(sample_path("bunny.ply").parent)
    return [path for folder in folders for path in sorted(folder.iterdir())
            if path.is_file() and is_model_file(path.name)]


def build_collection(root: Path, pool: Sequence[Path], n_files: int) -> Path:
    """``n_files`` files of ``pool`` in turn, as ``root/NNN/NNNNN_<name>`` (hard links)."""
    store = root.parent / ".pool"
    store.mkdir(parents=True, exist_ok=True)
    for index in range(n_files):
        source = pool[index % len(pool)]
        kept = store / f"{index % len(pool):04d}_{source.name}"
        if not kept.exists():
            shutil.copyfile(source, kept)
        target = root / f"{index // 100:03d}" / f"{index:05d}_{source.name}"
        target.parent.mkdir(parents=True, exist_ok=True)
        os.link(kept, target)
    return root


def _tree_rss(pid: int, main: int) -> tuple[int, int]:
    """Resident bytes of process ``main`` and of every other descendant of ``pid``."""
    import psutil

    main_rss = others = 0
    try:
        children = psutil.Process(pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return 0, 0
    for child in children:
        with contextlib.suppress(psutil.NoSuchProcess, psutil.AccessDenied):
            rss = child.memory_info().rss
            if child.pid == main:
                main_rss = rss
            else:
                others += rss
    return main_rss, others


@dataclass
class Sampler:
    """Resident memory of a ``vptool`` process and of the bench's other children, over time."""

    main: int
    streaming: Path | None = None
    samples: list[tuple[float, int, int, bool]] = field(default_factory=list)

    @contextlib.contextmanager
    def running(self) -> Iterator[Sampler]:
        stop = threading.Event()
        started = time.perf_counter()

        def sample() -> None:
            while not stop.wait(SAMPLE_EVERY_S):
                main, others = _tree_rss(os.getpid(), self.main)
                is_streaming = self.streaming is not None and any(
                    self.streaming.glob("*/.order.jsonl.partial"))
                if main:
                    self.samples.append((time.perf_counter() - started, main, others,
                                         is_streaming))

        thread = threading.Thread(target=sample, daemon=True)
        thread.start()
        try:
            yield self
        finally:
            stop.set()
            thread.join()

    def peaks_mb(self) -> tuple[float, float]:
        """Peak resident MB of the main process and of the workers together."""
        if not self.samples:
            return 0.0, 0.0
        return (max(s[1] for s in self.samples) / 1e6, max(s[2] for s in self.samples) / 1e6)


@dataclass(frozen=True)
class Run:
    """One ``vptool`` run: wall seconds, per-stage seconds summed, memory, the table."""

    wall: float
    n_answered: int
    stages: dict[str, float]
    per_file: dict[str, float]
    peak_main_mb: float
    peak_workers_mb: float
    table: bytes
    n_failed: int
    memory: list[tuple[float, int, int, bool]]

    @property
    def files_per_hour(self) -> float:
        return 3600.0 * self.n_answered / self.wall if self.wall else 0.0

    def overhead(self, workers: int) -> float:
        busy = sum(self.stages.values()) / workers
        return self.wall / busy - 1.0 if busy else float("nan")


def vptool(arguments: Sequence[str], log: Path, *, kill_when: Any = None,
           streaming: Path | None = None) -> tuple[float, Sampler]:
    """Run ``vptool arguments`` to its end (or SIGKILL it once ``kill_when()`` holds);
    its samples say whether it was streaming entries into ``streaming`` (the run's
    output folder, while its partial order file exists)."""
    started = time.perf_counter()
    with log.open("a") as stderr:
        process = subprocess.Popen([sys.executable, *VPTOOL, *arguments], stdout=stderr,
                                   stderr=stderr)
        sampler = Sampler(process.pid, streaming)
        with sampler.running():
            while process.poll() is None:
                if kill_when is not None and kill_when():
                    process.send_signal(signal.SIGKILL)
                    process.wait()
                    break
                time.sleep(0.05)
    if kill_when is None and process.returncode not in (0, 1):  # 1: some files failed
        raise RuntimeError(f"vptool {' '.join(arguments)} exited {process.returncode}; "
                           f"see {log}")
    return time.perf_counter() - started, sampler


def read_run(out: Path, wall: float, sampler: Sampler) -> Run:
    """The figures of a finished run whose output folder is ``out``."""
    import pyarrow.parquet as pq

    (timings,) = out.rglob("timings.jsonl")
    lines = [json.loads(line) for line in timings.read_text().splitlines()]
    (table,) = out.rglob("table.parquet")
    status = pq.read_table(table, columns=["status"]).column("status").to_pylist()
    main, workers = sampler.peaks_mb()
    return Run(wall, len(lines), {stage: sum(line[stage] for line in lines) for stage in STAGES},
               {line["key"]: line["seconds"] for line in lines}, main, workers,
               table.read_bytes(), sum(value != "ok" for value in status), sampler.samples)


def command(name: str, source: Path, out: Path, extra: Sequence[str] = ()) -> list[str]:
    """``best-view SOURCE -o OUT`` or ``thumbnails SOURCE OUT``, and ``extra``."""
    if name == "best-view":
        return ["best-view", str(source), "-o", str(out), *extra]
    return ["thumbnails", str(source), str(out), *extra]


@contextlib.contextmanager
def dask_cluster() -> Iterator[str | None]:
    """A LocalCluster of 2 worker processes of 1 thread each, or None without distributed."""
    try:
        from distributed import LocalCluster
    except ImportError:
        yield None
        return
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0") as cluster:
        yield cluster.scheduler_address


def bench_command(name: str, source: Path, work: Path, log: Path) -> dict[str, Run]:
    """One command over ``source`` with 1 and 2 local workers and a Dask cluster of 2."""
    runs: dict[str, Run] = {}
    for label, extra in (("1 process", ()), ("2 processes", ("--workers", "2"))):
        out = work / f"{name}-{label.replace(' ', '-')}"
        wall, sampler = vptool(command(name, source, out, extra), log)
        runs[label] = read_run(out, wall, sampler)
    with dask_cluster() as address:
        if address is not None:
            out = work / f"{name}-dask"
            wall, sampler = vptool(command(name, source, out, ("--scheduler", address)), log)
            runs["Dask, 2 processes"] = read_run(out, wall, sampler)
    return runs


def print_runs(name: str, n_files: int, runs: dict[str, Run]) -> None:
    print(f"\n{name}, {n_files} files, default settings:")
    print(f"  {'':<18} {'files/h':>8} {'wall':>7} {'overhead':>8} {'failed':>6} "
          f"{'main MB':>8} {'workers MB':>10}   seconds summed: "
          + " / ".join(STAGES))
    for label, run in runs.items():
        workers = 1 if label == "1 process" else 2
        print(f"  {label:<18} {run.files_per_hour:8.0f} {format_seconds(run.wall):>7} "
              f"{100 * run.overhead(workers):7.0f}% {run.n_failed:6d} "
              f"{run.peak_main_mb:8.0f} {run.peak_workers_mb:10.0f}   "
              + " / ".join(f"{run.stages[stage]:.1f}" for stage in STAGES))
    tables = {run.table for run in runs.values()}
    print(f"  the same table bytes in every run: {'yes' if len(tables) == 1 else 'NO'}")
    if "Dask, 2 processes" in runs:
        ratio = runs["Dask, 2 processes"].files_per_hour / runs["2 processes"].files_per_hour
        print(f"  Dask over 2 local processes: {ratio:.2f}x files/h "
              f"(target within 10 %: {'met' if abs(ratio - 1) <= 0.1 else 'MISSED'})")
    worst = max(run.overhead(1 if label == "1 process" else 2) for label, run in runs.items())
    print(f"  runner overhead at most {100 * worst:.0f} % "
          f"(target <= 10 %: {'met' if worst <= 0.1 else 'MISSED'})")


def bench_old_default(source: Path, work: Path, log: Path, default: Run) -> None:
    """Thumbnails at the default over the old default, median seconds per file, same files."""
    out = work / "thumbnails-old"
    wall, sampler = vptool(command("thumbnails", source, out, ("--views", "1000",
                                                               "--resolution", "1024")), log)
    old = read_run(out, wall, sampler)
    keys = sorted(old.per_file)
    old_s = statistics.median(old.per_file[key] for key in keys)
    new_s = statistics.median(default.per_file[key] for key in keys)
    ratio = old_s / new_s
    print(f"\nthumbnails, default (search) vs old default (--views 1000 --resolution 1024), "
          f"median over the same {len(keys)} files, 1 process:")
    print(f"  old default {old_s:.2f} s per file ({3600 / old_s:.0f} files/h), default "
          f"{new_s:.2f} s per file ({3600 / new_s:.0f} files/h): {ratio:.1f}x "
          f"(target >= 5x: {'met' if ratio >= 5 else 'MISSED'})")


def bench_kill(source: Path, work: Path, log: Path, n_files: int, reference: Run) -> None:
    """``kill -9`` of best-view (2 workers) once a third is staged; a rerun finishes it."""
    out = work / "best-view-killed"
    at = max(1, n_files // 3)

    def staged() -> int:
        return sum(1 for _ in out.rglob("staging/*/*.json"))

    arguments = command("best-view", source, out, ("--workers", "2"))
    vptool(arguments, log, kill_when=lambda: staged() >= at)
    time.sleep(1.0)  # the workers end with their caller
    kept = staged()
    (timings,) = out.rglob("timings.jsonl")
    before = len(timings.read_text().splitlines())
    wall, sampler = vptool(arguments, log)
    rerun = read_run(out, wall, sampler)
    redone = rerun.n_answered - before
    same = rerun.table == reference.table
    print(f"\nkill -9 of best-view (2 processes, at most 4 files in flight) once {at} of "
          f"{n_files} files were staged:")
    print(f"  staged when killed {kept}, answered by the rerun {redone} (the {n_files - kept} "
          f"not staged: {'yes' if redone == n_files - kept else 'NO'}); table bytes as an "
          f"uninterrupted run: {'identical' if same else 'DIFFERENT'}")


def bench_list(work: Path, log: Path, n_lines: int, n_run: int) -> None:
    """Memory while streaming a list of ``n_lines`` lines: a dry run of it all, a run of its
    first ``n_run`` lines."""
    folder = work / "listed"
    (folder / "small").mkdir(parents=True)
    for name in SMALL_SAMPLES:
        shutil.copyfile(sample_path(name), folder / "small" / name)
    whole, head = folder / "models.txt", folder / "head.txt"
    with whole.open("w") as lines, head.open("w") as first:
        for index in range(n_lines):
            line = f"small/{SMALL_SAMPLES[index % len(SMALL_SAMPLES)]}\n"
            lines.write(line)
            if index < n_run:
                first.write(line)
    print(f"\na list of {n_lines} lines naming {len(SMALL_SAMPLES)} small sample files in "
          "turn, best-view, 1 process, resident MB of the calling process:")
    out = work / "listed-run"
    for label, arguments, streaming in (
            (f"--dry-run of all {n_lines} lines, over the run",
             ["best-view", f"@{whole}", "-o", str(work / "listed-dry"), "--dry-run"], None),
            (f"a run of the first {n_run} lines, while it streams them",
             ["best-view", f"@{head}", "-o", str(out)], out)):
        wall, sampler = vptool(arguments, log, streaming=streaming)
        rss = [s[1] / 1e6 for s in sampler.samples if streaming is None or s[3]]
        deciles = [rss[min(len(rss) - 1, len(rss) * k // 10)] for k in range(11)] if rss else []
        # flat: once started (a quarter in), the peak stays within 5 % of the value then
        steady = rss[len(rss) // 4:] or rss
        growth = max(steady) / steady[0] - 1 if steady else 0.0
        print(f"  {label}: {format_seconds(wall)}, at each tenth: "
              + " ".join(f"{value:.0f}" for value in deciles))
        print(f"    peak after a quarter over the value then: +{100 * growth:.1f} % "
              f"(flat, target <= 5 %: {'met' if growth <= 0.05 else 'MISSED'})")
        if streaming is not None:
            last = max((k for k, sample in enumerate(sampler.samples) if sample[3]), default=0)
            after = [sample[1] / 1e6 for sample in sampler.samples[last + 1:]]
            print(f"    then the table and predictions.npz of {n_run} rows: peak "
                  f"{max(after, default=0):.0f} MB")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", type=int, default=5000,
                        help="files of the collection (default: 5000; 12 with --quick)")
    parser.add_argument("--thumbnail-files", type=int,
                        help="files thumbnails runs over, the collection's first "
                             "(default: a fifth of --files)")
    parser.add_argument("--old-files", type=int, default=8,
                        help="files measured at the old thumbnail default (default: 8)")
    parser.add_argument("--list-lines", type=int, default=1_000_000,
                        help="lines of the list whose memory is sampled (default: 10^6)")
    parser.add_argument("--list-run", type=int, default=100_000,
                        help="of them, the lines a full run answers (default: 100,000)")
    parser.add_argument("--meshes", type=Path,
                        help="a folder holding gazebo_models/ and object_sim/ (licensed real "
                             "meshes), used beside the bundled samples (default: the samples "
                             "alone; --quick uses the samples alone)")
    parser.add_argument("--quick", action="store_true",
                        help="the samples, 12 files, 4 thumbnails, 1 old thumbnail, a list of "
                             "10,000 lines (a smoke test)")
    parser.add_argument("--work", type=Path, help="keep the collections and outputs here "
                        "(default: a temporary folder, removed)")
    parser.add_argument("--only", choices=("best-view", "thumbnails"),
                        help="bench one command's runs over 1 and 2 processes and Dask, "
                             "nothing else")
    parser.add_argument("--json", type=Path, help="also write the figures to this JSON file")
    add_results_option(parser, "collection")
    args = parser.parse_args()
    if args.quick:
        args.files, args.old_files = min(args.files, 12), 1
        args.list_lines, args.list_run = 10_000, 2000
    n_thumbs = args.thumbnail_files or max(1, args.files // 5)

    with printed_section(args.results, args.section), contextlib.ExitStack() as stack:
        work = args.work or Path(stack.enter_context(tempfile.TemporaryDirectory()))
        log = work / "vptool.log"
        work.mkdir(parents=True, exist_ok=True)
        started = time.perf_counter()
        load_before = os.getloadavg()[0]
        meshes = None if args.quick else args.meshes
        pool = mesh_pool(meshes)
        source = build_collection(work / "collection", pool, args.files)
        thumbs = build_collection(work / "thumbnail-collection", pool, n_thumbs)
        old = build_collection(work / "old-collection", pool, min(args.old_files, n_thumbs))
        folders = "the samples" if meshes is None else f"{', '.join(MESH_FOLDERS)}, the samples"
        print(f"{args.files} files: {len(pool)} real meshes in turn ({folders}), "
              f"hard links; {os.cpu_count()} CPUs, load average {load_before:.2f}")
        best = pictures = {}
        if args.only != "thumbnails":
            best = bench_command("best-view", source, work, log)
            print_runs("best-view", args.files, best)
        if args.only != "best-view":
            pictures = bench_command("thumbnails", thumbs, work, log)
            print_runs("thumbnails", n_thumbs, pictures)
        if args.only is None:
            bench_old_default(old, work, log, pictures["1 process"])
            bench_kill(source, work, log, args.files, best["1 process"])
            bench_list(work, log, args.list_lines, args.list_run)
        print(f"\nload average {load_before:.2f} before, {os.getloadavg()[0]:.2f} after; "
              f"the bench took {format_seconds(time.perf_counter() - started)}")
        if args.json:
            figures = {name: {label: {"files_per_hour": run.files_per_hour, "wall": run.wall,
                                      "stages": run.stages, "peak_main_mb": run.peak_main_mb,
                                      "peak_workers_mb": run.peak_workers_mb,
                                      "failed": run.n_failed}
                              for label, run in runs.items()}
                       for name, runs in (("best-view", best), ("thumbnails", pictures))}
            args.json.write_text(json.dumps(figures, indent=2) + "\n")


if __name__ == "__main__":
    main()
