"""Benchmark: seconds per picture of Open3D's offscreen renderer, in its child process.

Prints, for a few bundled meshes:

* the start-up of a render child (importing Open3D, creating the renderer and
  drawing a warm-up frame), paid once per :class:`vptoolkit.render.Renderer`;
* seconds per frame at 256, 512 and 1024 px (median of several directions,
  the mesh already sent to the child);
* beside them, in the same run, the seconds of the measures for 1000 views at
  1024 px (:func:`vptoolkit.measures.compute_view_quality`), and the ratio
  "one picture / all the measures", so the cost of a thumbnail can be read
  against the cost of finding its view on this machine, whatever its load;
* the 1-minute load average before and after.

Usage::

    python tools/bench_render.py            # about a minute
    python tools/bench_render.py --quick    # 256 and 512 px, one mesh
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from vptoolkit.io import load_mesh
from vptoolkit.measures import compute_view_quality
from vptoolkit.render import Renderer
from vptoolkit.samples import sample_path
from vptoolkit.sphere import fibonacci_sphere

MESHES = ("bunny.ply", "teapot.stl", "Duck.glb")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer sizes, one mesh")
    args = parser.parse_args()
    sizes = (256, 512) if args.quick else (256, 512, 1024)
    meshes = [load_mesh(sample_path(name)) for name in (MESHES[:1] if args.quick else MESHES)]
    directions = fibonacci_sphere(7 if args.quick else 15)
    load_before = os.getloadavg()[0]
    compute_view_quality(meshes[0], n_views=2, resolution=64)  # compile the rasteriser first

    print(f"{'mesh':<10} {'faces':>7} {'measures 1000 views':>20} "
          + " ".join(f"{f'{size} px frame':>14}" for size in sizes) + "  frame/measures")
    startups = []
    for mesh in meshes:
        started = time.perf_counter()
        compute_view_quality(mesh, n_views=1000, resolution=1024)
        measures_seconds = time.perf_counter() - started
        frames = []
        for size in sizes:
            with Renderer(size=size) as renderer:
                started = time.perf_counter()
                renderer.start()
                startups.append(time.perf_counter() - started)
                renderer.render(mesh, directions[:1])  # send the mesh once
                times = []
                for direction in directions:
                    started = time.perf_counter()
                    renderer.render(mesh, direction)
                    times.append(time.perf_counter() - started)
            frames.append(statistics.median(times))
        print(f"{mesh.name:<10} {mesh.n_faces:>7} {measures_seconds:>18.2f} s "
              + " ".join(f"{seconds:>12.3f} s" for seconds in frames)
              + f"  {frames[min(1, len(frames) - 1)] / measures_seconds:>8.2f} (512 px)")
    print(f"render child start-up: median {np.median(startups):.2f} s over {len(startups)} starts")
    print(f"load average {load_before:.2f} before, {os.getloadavg()[0]:.2f} after "
          "(the numbers mean most on an idle machine)")


if __name__ == "__main__":
    main()
