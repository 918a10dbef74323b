"""Benchmark: what a view set costs on top of the measures.

For each mesh, in one run and with the same views and resolution:

* ``quality s``: :func:`vptoolkit.measures.quality.compute_view_quality` alone;
* ``both s``: :func:`vptoolkit.view_sets.search.measure_view_set` (the measures and a
  4-view coverage set from one drawing of the views) and its extra time over
  ``quality s`` in percent (target: under 10 % at 1000 views);
* the search alone, on pixel counts already drawn, per objective
  (coverage, quality, information), in milliseconds.

Each time is the best of ``--repeats`` runs (other jobs share the machine).

Usage::

    python tools/bench_view_sets.py            # 1000 views at 1024 px, a minute or two
    python tools/bench_view_sets.py --quick    # 200 views at 256 px, seconds
    python tools/bench_view_sets.py --results docs/benchmarks.md   # and its section ``view_sets``
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from typing import Any

from results_doc import add_results_option, printed_section

from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.synthetic import make_shape
from vptoolkit.view_sets.search import OBJECTIVES, best_view_set, measure_view_set
from vptoolkit.view_sets.visibility import FaceVisibility


def best_seconds(work: Callable[[], Any], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        work()
        times.append(time.perf_counter() - started)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="few views, low resolution")
    parser.add_argument("--k", type=int, default=4, help="views per set (default: 4)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="also write the results to this JSON file")
    add_results_option(parser, "view_sets")
    args = parser.parse_args()
    with printed_section(args.results, args.section):
        if args.quick:
            n_views, resolution, repeats = 200, 256, 1
            meshes = [load_mesh(sample_path("torus.STL"))]
        else:
            n_views, resolution, repeats = 1000, 1024, args.repeats
            meshes = [make_shape("airplane", seed=0), load_mesh(sample_path("torus.STL")),
                      load_mesh(sample_path("bunny.ply"))]
        # load the rasteriser
        compute_view_quality(meshes[0], MeasureSettings(views=8, resolution=16))
        print(f"{n_views} views at {resolution} px, k = {args.k}, best of {repeats} runs\n")
        header = (f"{'mesh':<12}{'faces':>8}{'quality s':>11}{'both s':>9}{'extra':>8}"
                  + "".join(f"{name + ' ms':>16}" for name in OBJECTIVES))
        print(header)
        print("-" * len(header))
        results = []
        settings = MeasureSettings(views=n_views, resolution=resolution)
        for mesh in meshes:
            alone = best_seconds(lambda: compute_view_quality(mesh, settings), repeats)
            both = best_seconds(lambda: measure_view_set(mesh, args.k, settings=settings), repeats)
            visibility = FaceVisibility.from_mesh(mesh, settings)
            search = {name: best_seconds(lambda: best_view_set(visibility, args.k, objective=name),
                                         repeats) for name in OBJECTIVES}
            extra = 100.0 * (both - alone) / alone
            print(f"{mesh.name:<12}{mesh.n_faces:>8}{alone:>11.2f}{both:>9.2f}{extra:>7.1f}%"
                  + "".join(f"{1000 * search[name]:>16.1f}" for name in OBJECTIVES))
            results.append({"mesh": mesh.name, "faces": mesh.n_faces, "n_views": n_views,
                            "resolution": resolution, "quality_s": alone, "both_s": both,
                            "extra_percent": extra,
                            "search_ms": {name: 1000 * s for name, s in search.items()}})
        if args.json:
            with open(args.json, "w") as handle:
                json.dump(results, handle, indent=2)


if __name__ == "__main__":
    main()
