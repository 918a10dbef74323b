"""Benchmark: seconds for 1000 views per backend and resolution, and what a
coarse resolution costs in best-view accuracy.

Prints, for meshes of about 10k, 100k and 1M faces (sample meshes,
midpoint-subdivided to size):

* seconds of the rasteriser for all views at 256, 512 and 1024 pixels, best
  of ``--repeat``;
* with ``--baseline DIR``, beside them the seconds of the rasteriser of the
  vptoolkit checked out in DIR (``git worktree add DIR REV``), timed on the
  same mesh and views in a child process run there with ``PYTHONPATH`` DIR,
  alternately with this code's runs so that both see the same machine load,
  and the speed-up of this code over it;
* seconds of Open3D's ray caster, timed on ``--raycast-views`` views and
  scaled to all views, and the ratio raycast / raster from the same run;
* how far the best view per measure at 256 and 512 lies from the one at
  1024 (degrees) and how much normalised quality (at 1024) it loses;
* the cost of every measure of the registry beside the paper's four: the
  seconds of ``compute_view_quality`` with the four and with all of them,
  alternately in one run, and their ratio; the drawing pass with and without
  the depth and silhouette statistics; and the seconds each family adds on
  top of the drawn views (its measures computed on one ``ViewData``);
* the JIT compile time (cold cache) and the cached start-up time, apart;
* the peak resident memory of the process after the largest mesh;
* with ``--memory-only``, the peak memory of ``compute_view_quality`` with
  ``--measures VE``, ``paper`` and ``VE,NVT`` on the bunny, each in a fresh
  process: the peak of the memory Python and numpy allocate while measuring
  (``tracemalloc``) and the process's peak resident memory; VE alone streams
  like the paper's four, a measure that reads the kept pixel counts (NVT)
  keeps them.
* with ``--neighbour-memory``, alone: the peak resident memory and seconds of
  the stability measures (INS, DVS, which read each view's nearest views) at
  1,000, 10,000 and 100,000 views, each in a fresh process, beside VE alone on
  the same views (the drawing's share).

Usage::

    python tools/bench_measures.py            # full run, a few minutes
    python tools/bench_measures.py --quick    # small sizes, seconds
    python tools/bench_measures.py --max-faces 200000   # without the 1M-face mesh
    python tools/bench_measures.py --max-faces 200000 --baseline /tmp/base --repeat 2
    # write section ``measures``:
    python tools/bench_measures.py --max-faces 200000 --results docs/benchmarks.md
    # all measures against the four, alone, into section ``measure_costs``:
    python tools/bench_measures.py --costs-only --results docs/benchmarks.md \
        --section measure_costs
    # peak memory of one measure against the paper's four, into section ``measure_memory``:
    python tools/bench_measures.py --memory-only --results docs/benchmarks.md \
        --section measure_memory
    # memory of INS and DVS against the number of views, into section ``neighbour_memory``:
    python tools/bench_measures.py --neighbour-memory --results docs/benchmarks.md \
        --section neighbour_memory
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from results_doc import add_results_option, printed_section

from vptoolkit.io import load_mesh
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import FAMILIES
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.registry import PAPER_MEASURES, all_measures
from vptoolkit.mesh import Mesh
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import angle_between_deg, fibonacci_sphere
from vptoolkit.visibility import iter_view_histograms


def subdivide(mesh: Mesh, times: int) -> Mesh:
    """Split every triangle into four at its edge midpoints, ``times`` times."""
    import trimesh.remesh

    vertices, faces = mesh.vertices, mesh.faces
    for _ in range(times):
        vertices, faces = trimesh.remesh.subdivide(vertices, faces)
    return Mesh(vertices, faces, f"{mesh.name}/4^{times}")


def time_views(mesh: Mesh, views: np.ndarray, resolution: int, backend: str) -> float:
    started = time.perf_counter()
    settings = MeasureSettings(resolution=resolution, backend=backend)  # type: ignore[arg-type]
    for _ in iter_view_histograms(mesh, settings, view_directions=views):
        pass
    return time.perf_counter() - started


_CHILD_RASTER = """
import json, sys, time
import numpy as np
import vptoolkit
from vptoolkit.mesh import Mesh
from vptoolkit.settings import MeasureSettings
from vptoolkit.visibility import iter_view_histograms
data = np.load(sys.argv[1])
mesh = Mesh(data["vertices"], data["faces"], name="baseline")
views, resolution = data["views"], int(sys.argv[2])
# load numba's cached kernels
for _ in iter_view_histograms(mesh, MeasureSettings(views=2, resolution=16)):
    pass
started = time.perf_counter()
for _ in iter_view_histograms(mesh, MeasureSettings(resolution=resolution), view_directions=views):
    pass
print(json.dumps({"seconds": time.perf_counter() - started, "code": vptoolkit.__file__}))
"""


def time_baseline(code: Path, mesh_file: Path, resolution: int) -> float:
    """Seconds of the raster backend of the vptoolkit at ``code``, in a child process run there.

    ``mesh_file`` is an ``.npz`` of ``vertices``, ``faces`` and ``views``.
    """
    done = subprocess.run(
        [sys.executable, "-c", _CHILD_RASTER, str(mesh_file), str(resolution)],
        env={**os.environ, "PYTHONPATH": str(code)}, cwd=code,
        capture_output=True, text=True, check=False,
    )
    if done.returncode != 0:
        raise SystemExit(f"bench_measures: the baseline raster failed:\n{done.stderr.strip()}")
    record = json.loads(done.stdout.strip().splitlines()[-1])
    if not Path(record["code"]).resolve().is_relative_to(code.resolve()):
        raise SystemExit(f"bench_measures: the baseline child imported {record['code']}, "
                         f"not {code}")
    return float(record["seconds"])


def time_measures(mesh: Mesh, views: np.ndarray, resolution: int, repeat: int) -> dict[str, float]:
    """Seconds of the paper's four against every registered measure, and per family.

    ``four_s`` and ``all_s`` are ``compute_view_quality`` with the default
    measures and with ``"all"``, best of ``repeat``, run alternately so both
    see the same machine load; ``draw_s`` and ``draw_features_s`` the drawing
    pass alone without and with the depth and silhouette statistics; each
    family's entry is the seconds its measures take on the drawn views, their
    shared per-mesh quantities (curvature, saliency, neighbours) included.
    """
    settings = MeasureSettings(resolution=resolution)
    four, every, draw, draw_features = [], [], [], []
    for _ in range(repeat):
        started = time.perf_counter()
        compute_view_quality(mesh, settings, view_directions=views)
        four.append(time.perf_counter() - started)
        started = time.perf_counter()
        compute_view_quality(mesh, settings, view_directions=views, measures="all")
        every.append(time.perf_counter() - started)
        started = time.perf_counter()
        runs = list(iter_view_histograms(mesh, settings, view_directions=views))
        draw.append(time.perf_counter() - started)
        started = time.perf_counter()
        runs = list(iter_view_histograms(mesh, settings, view_directions=views, features=True))
        draw_features.append(time.perf_counter() - started)
    record = {"four_s": min(four), "all_s": min(every), "draw_s": min(draw),
              "draw_features_s": min(draw_features)}
    from vptoolkit.geometry import face_areas

    for family in FAMILIES:
        data = ViewData(mesh, views, settings, face_areas(mesh), runs)
        started = time.perf_counter()
        for measure in all_measures().values():
            if measure.family == family:
                measure.compute(data)
        record[family] = time.perf_counter() - started
    return record


def print_measure_costs(mesh: Mesh, views: np.ndarray, resolution: int,
                        repeat: int) -> dict[str, float]:
    """Print and return :func:`time_measures` of one mesh."""
    record = time_measures(mesh, views, resolution, repeat)
    print(f"\nall {len(all_measures())} measures against the paper's four: {mesh.name}, "
          f"{mesh.n_faces} faces, {len(views)} views at {resolution} px, best of {repeat}")
    print(f"  the four: {record['four_s']:.2f} s; all: {record['all_s']:.2f} s; "
          f"ratio {record['all_s'] / record['four_s']:.2f}")
    print(f"  drawing: {record['draw_s']:.2f} s; with depth and silhouette statistics: "
          f"{record['draw_features_s']:.2f} s "
          f"(x{record['draw_features_s'] / record['draw_s']:.2f})")
    for family in FAMILIES:
        names = ", ".join(m.name for m in all_measures().values() if m.family == family)
        print(f"  {family:<12}{record[family]:>7.2f} s on the drawn views  ({names})")
    return {"mesh": mesh.name, "faces": mesh.n_faces, "resolution": resolution, **record}


MEMORY_SPECS = ("VE", "paper", "VE,NVT")
"""The ``--measures`` values whose peak memory ``--memory-only`` compares."""

_CHILD_MEMORY = """
import json, resource, sys, tracemalloc
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
mesh = load_mesh(sample_path(sys.argv[1]))
spec = sys.argv[4]
compute_view_quality(mesh, MeasureSettings(views=2, resolution=16), measures=spec)  # JIT load
tracemalloc.start()
compute_view_quality(mesh, MeasureSettings(views=int(sys.argv[2]), resolution=int(sys.argv[3])),
                     measures=spec)
traced = tracemalloc.get_traced_memory()[1]
resident = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"traced_mb": traced / 2**20, "resident_mb": resident / 1024}))
"""


def peak_memory(sample: str, n_views: int, resolution: int, spec: str) -> dict[str, float]:
    """Peak memory in MiB of ``compute_view_quality(..., measures=spec)`` on a sample mesh, in
    a fresh process: ``traced_mb`` what Python and numpy allocate while measuring
    (``tracemalloc``), ``resident_mb`` the process's peak resident memory."""
    done = subprocess.run([sys.executable, "-c", _CHILD_MEMORY, sample, str(n_views),
                           str(resolution), spec], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"bench_measures: the memory child failed:\n{done.stderr.strip()}")
    record: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    return record


def print_peak_memory(sample: str, n_views: int, resolution: int) -> list[dict[str, object]]:
    """Print and return :func:`peak_memory` of each of :data:`MEMORY_SPECS`."""
    mesh = load_mesh(sample_path(sample))
    print(f"peak memory of compute_view_quality: {mesh.name}, {mesh.n_faces} faces, "
          f"{n_views} views at {resolution} px, each in a fresh process")
    records: list[dict[str, object]] = []
    for spec in MEMORY_SPECS:
        record = peak_memory(sample, n_views, resolution, spec)
        print(f"  --measures {spec:<8} traced peak {record['traced_mb']:>7.1f} MiB, "
              f"resident peak {record['resident_mb']:>7.1f} MiB")
        records.append({"measures": spec, **record})
    return records


NEIGHBOUR_VIEWS = (1_000, 10_000, 100_000)
"""View counts of ``--neighbour-memory``."""


def measure_memory(measures: str, n_views: int) -> tuple[float, float]:
    """Peak resident MB and seconds of ``compute_view_quality`` of a tetrahedron at 8 px with
    ``measures`` on ``n_views`` Fibonacci views, in a fresh process."""
    code = (
        "import resource, sys, time, numpy as np;"
        "from vptoolkit.mesh import Mesh; from vptoolkit.settings import MeasureSettings;"
        "from vptoolkit.measures.quality import compute_view_quality;"
        "tet = Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float),"
        " [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], 'tet');"
        "compute_view_quality(tet, MeasureSettings(views=2, resolution=8), measures='VE');"
        "t = time.perf_counter();"
        f"compute_view_quality(tet, MeasureSettings(views={n_views}, resolution=8),"
        f" measures='{measures}');"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,"
        " time.perf_counter() - t)"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                         text=True).stdout.split()
    return float(out[0]), float(out[1])


def print_neighbour_memory(view_counts: tuple[int, ...]) -> None:
    """Print :func:`measure_memory` of INS, DVS and VE alone at each of ``view_counts``."""
    print("peak resident memory of a fresh process measuring a tetrahedron at 8 px")
    header = f"{'views':>9}{'INS,DVS MB':>12}{'s':>8}{'VE MB':>9}{'s':>8}"
    print(header)
    print("-" * len(header))
    for n_views in view_counts:
        stability_mb, stability_s = measure_memory("INS,DVS", n_views)
        alone_mb, alone_s = measure_memory("VE", n_views)
        print(f"{n_views:>9,}{stability_mb:>12.0f}{stability_s:>8.1f}{alone_mb:>9.0f}"
              f"{alone_s:>8.1f}")


def jit_seconds() -> tuple[float, float]:
    """Seconds for the first tiny rasterisation in a fresh process: cold cache, then warm."""
    code = (
        "import time, numpy as np; t = time.perf_counter();"
        "from vptoolkit.mesh import Mesh; from vptoolkit.visibility import face_pixel_counts;"
        "from vptoolkit.settings import MeasureSettings;"
        "face_pixel_counts(Mesh(np.eye(3), [[0, 1, 2]]), MeasureSettings(views=1, resolution=8),"
        " view_directions=[[1, 1, 1]]);"
        "print(time.perf_counter() - t)"
    )
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        runs = [
            float(subprocess.run([sys.executable, "-c", code], env=env, check=True,
                                 capture_output=True, text=True).stdout)
            for _ in range(2)
        ]
    return runs[0], runs[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small meshes and few views")
    parser.add_argument("--views", type=int, default=1000)
    parser.add_argument("--raycast-views", type=int, default=40)
    parser.add_argument("--repeat", type=int, default=3,
                        help="best of this many raster runs of each code (default: 3)")
    parser.add_argument("--max-faces", type=int, help="skip meshes with more faces")
    parser.add_argument("--baseline", type=Path,
                        help="a checkout of other vptoolkit code to time beside this one")
    parser.add_argument("--json", help="also write the results to this JSON file")
    parser.add_argument("--costs-only", action="store_true",
                        help="only the cost of all measures against the paper's four "
                             "(the torus at the finest resolution)")
    parser.add_argument("--memory-only", action="store_true",
                        help="only the peak memory of --measures VE, paper and VE,NVT "
                             "(the bunny; the torus with --quick)")
    parser.add_argument("--neighbour-memory", action="store_true",
                        help="only the peak memory of INS and DVS at 1,000 to 100,000 views "
                             "(200 and 2,000 with --quick)")
    add_results_option(parser, "measures")
    args = parser.parse_args()
    if args.baseline is not None and not (args.baseline / "vptoolkit" / "__init__.py").is_file():
        parser.error(f"--baseline: {args.baseline} holds no vptoolkit package")

    with printed_section(args.results, args.section):
        if args.neighbour_memory:
            print_neighbour_memory((200, 2_000) if args.quick else NEIGHBOUR_VIEWS)
            return
        torus = load_mesh(sample_path("torus.STL"))
        bunny = load_mesh(sample_path("bunny.ply"))
        if args.quick:
            meshes = [torus, subdivide(torus, 1)]
            resolutions = [128, 256]
            n_views, raycast_views = 100, 8
        else:
            meshes = [torus, bunny, subdivide(torus, 2), subdivide(bunny, 3)]
            resolutions = [256, 512, 1024]
            n_views, raycast_views = args.views, args.raycast_views
        if args.max_faces is not None:
            meshes = [mesh for mesh in meshes if mesh.n_faces <= args.max_faces]
        views = fibonacci_sphere(n_views)
        if args.memory_only:
            print_peak_memory("torus.STL" if args.quick else "bunny.ply", n_views,
                              resolutions[-1])
            return
        if args.costs_only:
            compute_view_quality(torus, MeasureSettings(views=2, resolution=16), measures="all")
            print_measure_costs(torus, views, resolutions[-1], args.repeat)
            return
        cold, warm = jit_seconds()
        # imports and JIT load happen here, not in the timings
        for backend in ("raster", "raycast"):
            time_views(torus, views[:2], 16, backend)
        print(f"JIT: {cold:.2f} s cold (compile), {warm:.2f} s with numba's on-disk cache")
        print(f"{n_views} views; raycast timed on {raycast_views} views and scaled")
        print(f"raster: best of {args.repeat}" + (
            f"; baseline: the code in {args.baseline}, alternately in the same run\n"
            if args.baseline is not None else "\n"))
        baseline_cells = f"{'baseline s':>11}{'speed-up':>10}" if args.baseline is not None else ""
        header = (f"{'mesh':<14}{'faces':>9}{'px':>6}{'raster s':>10}{baseline_cells}"
                  f"{'raycast s':>11}{'ratio':>8}")
        print(header)
        print("-" * len(header))
        results = []
        finest = resolutions[-1]
        with tempfile.TemporaryDirectory(prefix="bench_measures_") as scratch:
            mesh_file = Path(scratch) / "mesh.npz"
            for mesh in meshes:
                np.savez(mesh_file, vertices=mesh.vertices, faces=mesh.faces, views=views)
                qualities = {}
                for resolution in resolutions:
                    runs: list[float] = []
                    baseline_runs: list[float] = []
                    for _ in range(args.repeat):  # alternately, so both see the same machine load
                        runs.append(time_views(mesh, views, resolution, "raster"))
                        if args.baseline is not None:
                            baseline_runs.append(
                                time_baseline(args.baseline, mesh_file, resolution))
                    raster = min(runs)
                    raycast = time_views(mesh, views[:raycast_views], resolution, "raycast")
                    raycast *= n_views / raycast_views
                    record = {"mesh": mesh.name, "faces": mesh.n_faces, "resolution": resolution,
                              "raster_s": raster, "raycast_s": raycast}
                    cells = ""
                    if baseline_runs:
                        baseline = min(baseline_runs)
                        cells = f"{baseline:>11.2f}{baseline / raster:>10.2f}"
                        record["raster_baseline_s"] = baseline
                    print(f"{mesh.name:<14}{mesh.n_faces:>9}{resolution:>6}{raster:>10.2f}{cells}"
                          f"{raycast:>11.1f}{raycast / raster:>8.1f}")
                    qualities[resolution] = compute_view_quality(
                        mesh, MeasureSettings(resolution=resolution), view_directions=views)
                    results.append(record)
                reference = qualities[finest]
                for resolution in resolutions[:-1]:
                    coarse = qualities[resolution]
                    angles = angle_between_deg(coarse.best_views, reference.best_views)
                    lost = 1.0 - reference.normalized[coarse.best_index,
                                                      np.arange(len(PAPER_MEASURES))]
                    cells = "  ".join(f"{m} {a:5.1f} deg -{q:.3f}"
                                      for m, a, q in zip(PAPER_MEASURES, angles, lost))
                    print(f"{'':<14}best view at {resolution} vs {finest}: {cells}")
                    results.append({"mesh": mesh.name, "resolution": resolution, "vs": finest,
                                    "angle_deg": angles.tolist(), "quality_lost": lost.tolist()})
        # the torus has 8,700 faces: the 10k-face mesh at the finest resolution
        results.append(print_measure_costs(torus, views, finest, args.repeat))
        peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"\npeak resident memory of this process: {peak_mb:.0f} MB")
        if args.json:
            with open(args.json, "w") as handle:
                json.dump({"jit_cold_s": cold, "jit_warm_s": warm, "peak_mb": peak_mb,
                           "baseline": str(args.baseline) if args.baseline else None,
                           "results": results}, handle, indent=2)


if __name__ == "__main__":
    main()
