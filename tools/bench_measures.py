"""Benchmark: seconds for 1000 views per backend and resolution, and what a
coarse resolution costs in best-view accuracy.

Prints, for meshes of about 10k, 100k and 1M faces (sample meshes,
midpoint-subdivided to size):

* seconds of the rasteriser for all views at 256, 512 and 1024 pixels, beside
  its kernel before issue 15 (the per-row division and float walk of the
  inverse depth, with the run-by-run histogram: ``visibility._raster_reference``,
  compiled apart) and the speed-up, timed in the same run, alternately, best
  of ``--repeat``: that kernel stays selectable by the private
  ``reference=True`` of ``vptoolkit.visibility._raster_view_histograms``,
  which ``tests/test_raster_kernel.py`` also runs to check that the counts are
  the same bit for bit;
* seconds of Open3D's ray caster, timed on ``--raycast-views`` views and
  scaled to all views, and the ratio raycast / raster from the same run;
* how far the best view per measure at 256 and 512 lies from the one at
  1024 (degrees) and how much normalised quality (at 1024) it loses;
* the JIT compile time (cold cache) and the cached start-up time, apart;
* the peak resident memory of the process after the largest mesh.

Usage::

    python tools/bench_measures.py            # full run, a few minutes
    python tools/bench_measures.py --quick    # small sizes, seconds
    python tools/bench_measures.py --max-faces 200000   # without the 1M-face mesh
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

import numpy as np

from vptoolkit.conventions import MEASURES
from vptoolkit.io import load_mesh
from vptoolkit.measures import compute_view_quality
from vptoolkit.mesh import Mesh
from vptoolkit.samples import sample_path
from vptoolkit.sphere import angle_between_deg, fibonacci_sphere
from vptoolkit.visibility import _raster_view_histograms, iter_view_histograms


def subdivide(mesh: Mesh, times: int) -> Mesh:
    """Split every triangle into four at its edge midpoints, ``times`` times."""
    import trimesh.remesh

    vertices, faces = mesh.vertices, mesh.faces
    for _ in range(times):
        vertices, faces = trimesh.remesh.subdivide(vertices, faces)
    return Mesh(vertices, faces, f"{mesh.name}/4^{times}")


def time_views(mesh: Mesh, views: np.ndarray, resolution: int, backend: str) -> float:
    started = time.perf_counter()
    for _ in iter_view_histograms(mesh, views, resolution=resolution, backend=backend):  # type: ignore[arg-type]
        pass
    return time.perf_counter() - started


def time_raster(mesh: Mesh, views: np.ndarray, resolution: int, reference: bool) -> float:
    started = time.perf_counter()
    for _ in _raster_view_histograms(mesh, views, resolution=resolution, reference=reference):
        pass
    return time.perf_counter() - started


def jit_seconds() -> tuple[float, float]:
    """Seconds for the first tiny rasterisation in a fresh process: cold cache, then warm."""
    code = (
        "import time, numpy as np; t = time.perf_counter();"
        "from vptoolkit.mesh import Mesh; from vptoolkit.visibility import face_pixel_counts;"
        "face_pixel_counts(Mesh(np.eye(3), [[0, 1, 2]]), [[1, 1, 1]], resolution=8);"
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
                        help="best of this many runs of each raster kernel (default: 3)")
    parser.add_argument("--max-faces", type=int, help="skip meshes with more faces")
    parser.add_argument("--json", help="also write the results to this JSON file")
    args = parser.parse_args()

    torus = load_mesh(sample_path("torus.STL"))
    bunny = load_mesh(sample_path("bunny.ply"))
    if args.quick:
        meshes = [torus, subdivide(torus, 1)]
        resolutions = [128, 256]
        n_views, raycast_views = 100, 8
    else:
        meshes = [torus, bunny, subdivide(torus, 2), subdivide(bunny, 3)]
    if args.max_faces is not None:
        meshes = [mesh for mesh in meshes if mesh.n_faces <= args.max_faces]
        resolutions = [256, 512, 1024]
        n_views, raycast_views = args.views, args.raycast_views
    views = fibonacci_sphere(n_views)
    cold, warm = jit_seconds()
    for backend in ("raster", "raycast"):  # imports and JIT load happen here, not in the timings
        time_views(torus, views[:2], 16, backend)
    time_raster(torus, views[:2], 16, reference=True)
    print(f"JIT: {cold:.2f} s cold (compile), {warm:.2f} s with numba's on-disk cache")
    print(f"{n_views} views; raycast timed on {raycast_views} views and scaled\n")
    print(f"raster: best of {args.repeat}; before: the kernel before issue 15, same run\n")
    header = (f"{'mesh':<14}{'faces':>9}{'px':>6}{'raster s':>10}{'before s':>10}{'speed-up':>10}"
              f"{'raycast s':>11}{'ratio':>8}")
    print(header)
    print("-" * len(header))
    results = []
    finest = resolutions[-1]
    for mesh in meshes:
        qualities = {}
        for resolution in resolutions:
            runs: dict[bool, list[float]] = {False: [], True: []}
            for _ in range(args.repeat):  # alternately, so both see the same machine load
                for reference in (False, True):
                    runs[reference].append(time_raster(mesh, views, resolution, reference))
            raster, before = min(runs[False]), min(runs[True])
            raycast = time_views(mesh, views[:raycast_views], resolution, "raycast")
            raycast *= n_views / raycast_views
            print(f"{mesh.name:<14}{mesh.n_faces:>9}{resolution:>6}{raster:>10.2f}{before:>10.2f}"
                  f"{before / raster:>10.2f}{raycast:>11.1f}{raycast / raster:>8.1f}")
            qualities[resolution] = compute_view_quality(mesh, view_directions=views,
                                                         resolution=resolution)
            results.append({"mesh": mesh.name, "faces": mesh.n_faces, "resolution": resolution,
                             "raster_s": raster, "raster_before_s": before,
                             "raycast_s": raycast})
        reference = qualities[finest]
        for resolution in resolutions[:-1]:
            coarse = qualities[resolution]
            angles = angle_between_deg(coarse.best_views, reference.best_views)
            lost = 1.0 - reference.normalized[coarse.best_index, np.arange(len(MEASURES))]
            cells = "  ".join(f"{m} {a:5.1f} deg -{q:.3f}" for m, a, q in zip(MEASURES, angles, lost))
            print(f"{'':<14}best view at {resolution} vs {finest}: {cells}")
            results.append({"mesh": mesh.name, "resolution": resolution, "vs": finest,
                            "angle_deg": angles.tolist(), "quality_lost": lost.tolist()})
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak resident memory of this process: {peak_mb:.0f} MB")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump({"jit_cold_s": cold, "jit_warm_s": warm, "peak_mb": peak_mb,
                       "results": results}, handle, indent=2)


if __name__ == "__main__":
    main()
