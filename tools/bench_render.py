"""Benchmark: seconds per picture of both picture engines.

Prints, for a few bundled meshes and each engine (``software``: the
measures' rasteriser and numpy shading; ``open3d``: Filament in a child
process):

* the start-up of a render child (importing Open3D, creating the renderer and
  drawing a warm-up frame), paid once per :class:`vptoolkit.pictures.open3d_engine.Renderer`;
* seconds per frame at 256, 512 and 1024 px: median and maximum over several
  directions (the mesh already prepared); Open3D frames that hang past 60 s
  count as failures;
* beside them, in the same run, the seconds of the measures for 1000 views at
  1024 px (:func:`vptoolkit.measures.quality.compute_view_quality`), and the ratio
  "one picture / all the measures", so the cost of a thumbnail can be read
  against the cost of finding its view on this machine, whatever its load;
* the 1-minute load average before and after.

Usage::

    python tools/bench_render.py            # about a minute
    python tools/bench_render.py --quick    # 256 and 512 px, one mesh
    python tools/bench_render.py --results docs/benchmarks.md   # and its section ``render``
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np
from results_doc import add_results_option, printed_section

from vptoolkit.errors import MeasurementError
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.pictures.open3d_engine import Renderer
from vptoolkit.pictures.software_engine import SoftwareRenderer
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere

MESHES = ("bunny.ply", "teapot.stl", "Duck.glb")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer sizes, one mesh")
    add_results_option(parser, "render")
    args = parser.parse_args()
    with printed_section(args.results, args.section):
        sizes = (256, 512) if args.quick else (256, 512, 1024)
        meshes = [load_mesh(sample_path(name)) for name in (MESHES[:1] if args.quick else MESHES)]
        directions = fibonacci_sphere(5 if args.quick else 8)
        load_before = os.getloadavg()[0]
        compute_view_quality(meshes[0], MeasureSettings(views=2, resolution=64))  # compile it first

        print(f"{'engine':<9} {'mesh':<10} {'faces':>7} {'measures':>10} "
              + " ".join(f"{f'{size} px median/max':>22}" for size in sizes) + "  frame/measures")
        startups = []
        for mesh in meshes:
            started = time.perf_counter()
            compute_view_quality(mesh, MeasureSettings(views=1000, resolution=1024))
            measures_seconds = time.perf_counter() - started
            for engine in ("software", "open3d"):
                cells, medians = [], []
                for size in sizes:
                    make = (SoftwareRenderer(size=size) if engine == "software"
                            else Renderer(size=size, frame_timeout=60.0, attempts=1))
                    with make as renderer:
                        started = time.perf_counter()
                        renderer.start()
                        if engine == "open3d":
                            startups.append(time.perf_counter() - started)
                        times, failed = [], 0
                        for direction in directions:
                            started = time.perf_counter()
                            try:
                                renderer.render(mesh, direction)
                            except MeasurementError:
                                failed += 1
                                continue
                            times.append(time.perf_counter() - started)
                    median = statistics.median(times) if times else float("nan")
                    medians.append(median)
                    cells.append(f"{median:>8.2f} / {max(times, default=float('nan')):>6.1f} s"
                                 + (f" {failed} hung" if failed else ""))
                print(f"{engine:<9} {mesh.name:<10} {mesh.n_faces:>7} {measures_seconds:>8.2f} s "
                      + " ".join(f"{cell:>22}" for cell in cells)
                      + f"  {medians[min(1, len(medians) - 1)] / measures_seconds:>8.3f} (512 px)")
        print(f"render child start-up: median {np.median(startups):.2f} s "
              f"over {len(startups)} starts")
        print(f"load average {load_before:.2f} before, {os.getloadavg()[0]:.2f} after "
              "(the numbers mean most on an idle machine)")


if __name__ == "__main__":
    main()
