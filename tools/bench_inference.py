"""Benchmark: milliseconds per model of the viewpoint network on this CPU.

Prints, beside the paper's timings on a GTX 1080 (Schelling et al. 2021,
table 3: 253-270 ms per model at batch 1, 10-20 ms at batch 64 and 7-17 ms at
batch 256, network only):

* the network alone (default architecture, ``direction`` heads; the weights
  do not change the cost) on 4096-point inputs of the sample meshes, in
  milliseconds per model at batch 1, 64 and 256, for 1 and 2 torch threads,
  split into the point hierarchy (no learned parameters) and the rest;
* end to end from a mesh file to four views: load, sample 20000 surface
  points, pick the 4096 inputs (1024 by farthest point sampling) and predict,
  per sample mesh, as :func:`vptoolkit.learn.predict.predict` does;
* the 1-minute load average before and after, since the numbers are only
  meaningful on an otherwise idle machine.

Each timing is the median of several repeats after a warm-up. The target is
at most 20 ms per model at batch 1.

Usage::

    python tools/bench_inference.py            # a minute or two
    python tools/bench_inference.py --quick    # batch 1 and 64, fewer repeats
    python tools/bench_inference.py --json results.json
    python tools/bench_inference.py --results docs/benchmarks.md   # and its section ``inference``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch
from results_doc import add_results_option, printed_section

from vptoolkit.io import load_mesh
from vptoolkit.learn.config import ModelConfig
from vptoolkit.learn.hierarchy import build_hierarchy
from vptoolkit.learn.model import ViewpointNet, save_model
from vptoolkit.learn.predict import network_points, predict
from vptoolkit.points import sample_surface
from vptoolkit.samples import sample_path

PAPER_MS = {1: "253-270", 64: "10-20", 256: "7-17"}
MESHES = ("bunny", "mug", "lego", "bottle", "table", "suzanne", "teapot", "Duck")


def median_ms(function: Callable[[], Any], repeats: int) -> float:
    function()
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return statistics.median(times) * 1000.0


def inputs_of_samples() -> torch.Tensor:
    clouds = []
    for name in MESHES:
        surface = sample_surface(load_mesh(sample_path(name)), 20000, seed=0).points
        clouds.append(network_points(surface, n_points=4096, n_fps=1024, seed=0, name=name))
    return torch.from_numpy(np.stack(clouds))


def bench_network(
    model: ViewpointNet, clouds: torch.Tensor, batch: int, repeats: int
) -> dict[str, float]:
    points = clouds[torch.arange(batch) % len(clouds)]
    with torch.inference_mode():
        total = median_ms(lambda: model(points), repeats)
        hierarchy = median_ms(lambda: build_hierarchy(points, model.config), repeats)
    return {"total": total / batch, "hierarchy": hierarchy / batch}


def bench_end_to_end(checkpoint: Path, repeats: int) -> dict[str, float]:
    result = {}
    for name in MESHES:
        path = sample_path(name)
        result[name] = median_ms(
            lambda path=path: predict(checkpoint, [path], batch_size=1), repeats)
    return result


def bench_stages(checkpoint: Path, name: str, repeats: int) -> dict[str, float]:
    """Where the end-to-end time of one mesh goes."""
    from vptoolkit.learn.model import load_model

    path = sample_path(name)
    mesh = load_mesh(path)
    surface = sample_surface(mesh, 20000, seed=0).points
    model, _ = load_model(checkpoint)
    points = torch.from_numpy(
        network_points(surface, n_points=4096, n_fps=1024, seed=0, name=name))[None]
    with torch.inference_mode():
        return {
            "load checkpoint": median_ms(lambda: load_model(checkpoint), repeats),
            "load mesh": median_ms(lambda: load_mesh(path), repeats),
            "sample 20000 points": median_ms(lambda: sample_surface(mesh, 20000, seed=0), repeats),
            "pick 4096 inputs": median_ms(
                lambda: network_points(surface, n_points=4096, n_fps=1024, seed=0, name=name),
                repeats),
            "network": median_ms(lambda: model(points), repeats),
        }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="batch 1 and 64 only, fewer repeats")
    parser.add_argument("--json", type=Path, help="also write the results to this JSON file")
    add_results_option(parser, "inference")
    args = parser.parse_args()

    with printed_section(args.results, args.section):
        load_before = os.getloadavg()[0]
        batches = (1, 64) if args.quick else (1, 64, 256)
        clouds = inputs_of_samples()
        model = ViewpointNet(ModelConfig()).eval()
        results: dict[str, Any] = {
            "cpu_count": os.cpu_count(), "torch": torch.__version__, "network_ms": {}}
        print(f"torch {torch.__version__}, {os.cpu_count()} CPUs, load average {load_before:.2f}")
        print(f"{'threads':>7} {'batch':>5} {'ms/model':>9} {'hierarchy':>9}  paper (GTX 1080)")
        default_threads = torch.get_num_threads()
        for threads in (1, 2):
            torch.set_num_threads(threads)
            for batch in batches:
                repeats = max(3, (20 if args.quick else 40) // batch)
                timing = bench_network(model, clouds, batch, repeats)
                results["network_ms"][f"{threads}x{batch}"] = timing
                print(f"{threads:>7} {batch:>5} {timing['total']:>9.2f} "
                      f"{timing['hierarchy']:>9.2f}  {PAPER_MS[batch]} ms")
        torch.set_num_threads(default_threads)

        with tempfile.TemporaryDirectory() as folder:
            checkpoint, _ = save_model(model, Path(folder) / "model.safetensors")
            repeats = 3 if args.quick else 5
            torch.set_num_threads(1)
            end_to_end = bench_end_to_end(checkpoint, repeats)
            stages = bench_stages(checkpoint, "bunny", repeats)
            torch.set_num_threads(default_threads)
        results["end_to_end_ms"] = end_to_end
        results["bunny_stages_ms"] = stages
        print("\nmesh to four views "
              "(1 thread; load, sample, pick inputs, load checkpoint, predict):")
        for name, ms in end_to_end.items():
            faces = load_mesh(sample_path(name)).n_faces
            print(f"  {name:<10} {faces:>7} faces {ms:8.1f} ms")
        print("bunny, by stage:")
        for stage, ms in stages.items():
            print(f"  {stage:<20} {ms:8.1f} ms")
        load_after = os.getloadavg()[0]
        results["load_average"] = [load_before, load_after]
        print(f"\nload average {load_before:.2f} before, {load_after:.2f} after "
              "(timings mean little on a busy machine)")
        if args.json:
            args.json.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
