"""Benchmark: milliseconds per point cloud of the viewpoint network's answer on this CPU.

A cloud is 20,000 surface points of a bundled sample mesh (seed 0); the
answer is what :func:`vptoolkit.learn.predict.network_predictor` gives with
the bundled network of coordinates alone (``points``), in process, the
network loaded once: the consensus of its answers to ``--inputs`` inputs of
4096 points per cloud (default :data:`~vptoolkit.learn.draws.N_INPUTS`, as
``vptool predict --inputs``).
Printed:

* single: one cloud per call, the median over the clouds and repeats;
* batched: ``--batch`` clouds per call (the samples in turn), per cloud: the
  clouds' inputs are drawn on as many threads as torch uses, then go through
  the network 64 inputs per forward pass (4 clouds; larger passes cost the
  same per input on a CPU and hold more memory);
* both as wall time and as the process's CPU time (all threads), which a
  busy machine inflates less;
* where the time of one cloud goes: the canonical order and content key of
  its points, the farthest point sampling, the whole choice of its inputs,
  the Morton codes and their sort (the first level of the point hierarchy),
  the whole point hierarchy of its inputs (no learned parameters), the
  network on them (hierarchy included) and the consensus;
* the 1-minute load average before and after, since the numbers are only
  meaningful on an otherwise idle machine.

Torch runs on ``--threads`` threads (default: 2). Each timing is the median
of several repeats after a warm-up.

Usage::

    python tools/bench_inference.py            # a few minutes
    python tools/bench_inference.py --quick    # 3 clouds, batch 8, fewer repeats
    python tools/bench_inference.py --inputs 1 # the network asked once a cloud
    nice -n 10 python tools/bench_inference.py --repeats 1   # batch 64, one repeat
    python tools/bench_inference.py --json results.json
    python tools/bench_inference.py --results docs/benchmarks.md   # and its section ``inference``
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch
from results_doc import add_results_option, printed_section

from vptoolkit.io import load_mesh
from vptoolkit.learn.consensus import consensus_directions
from vptoolkit.learn.draws import N_INPUTS, content_order, network_indices, network_inputs
from vptoolkit.learn.hierarchy import build_hierarchy, input_level
from vptoolkit.learn.predict import network_predictor, predict_directions
from vptoolkit.points import N_FPS_POINTS, N_NETWORK_POINTS, farthest_point_sampling, sample_surface
from vptoolkit.samples import sample_path

MESHES = ("bunny", "mug", "lego", "bottle", "table", "suzanne", "teapot", "Duck")
CLOUD_POINTS = 20000
INPUT: dict[str, Any] = {"n_points": N_NETWORK_POINTS, "n_fps": N_FPS_POINTS, "seed": 0}


def median_ms(function: Callable[[], Any], repeats: int) -> float:
    """Median wall time of ``function`` over ``repeats`` calls after one warm-up, in ms."""
    return median_times(function, repeats)[0]


def median_times(function: Callable[[], Any], repeats: int) -> tuple[float, float]:
    """Median wall and process CPU time (all threads) of ``function`` over ``repeats`` calls
    after one warm-up, in ms."""
    function()
    walls, cpus = [], []
    for _ in range(repeats):
        started, cpu = time.perf_counter(), time.process_time()
        function()
        walls.append(time.perf_counter() - started)
        cpus.append(time.process_time() - cpu)
    return statistics.median(walls) * 1000.0, statistics.median(cpus) * 1000.0


def sample_clouds(names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """20,000 surface points (seed 0) of each named bundled sample mesh."""
    return {name: sample_surface(load_mesh(sample_path(name)), CLOUD_POINTS, seed=0).points
            for name in names}


def bench_stages(clouds: dict[str, np.ndarray], repeats: int,
                 n_inputs: int = N_INPUTS) -> dict[str, float]:
    """Where the time of one cloud goes, in ms, the median over the clouds."""
    from vptoolkit.learn.model import load_model

    model, _ = load_model("points")
    model.eval()
    stages: dict[str, list[float]] = {}
    for name, cloud in clouds.items():
        inputs = torch.from_numpy(network_inputs(cloud, name=name, n_inputs=n_inputs, **INPUT))
        answers = predict_directions(model, inputs)[None]
        canonical = cloud[content_order(cloud)[0]]
        rng = np.random.default_rng(0)
        with torch.inference_mode():
            timed = {
                "canonical order and key": lambda: content_order(cloud),
                f"farthest point sampling ({N_FPS_POINTS})": lambda: farthest_point_sampling(
                    canonical, N_FPS_POINTS, rng=rng),
                f"choose {n_inputs} inputs": lambda: network_indices(
                    cloud, n_inputs=n_inputs, **INPUT),
                "Morton codes and sort": lambda: input_level(inputs),
                f"hierarchy of {n_inputs} inputs": lambda: build_hierarchy(inputs, model.config),
                f"network on {n_inputs} inputs": lambda: model(inputs),
                "consensus": lambda: consensus_directions(answers),
            }
            for stage, function in timed.items():
                stages.setdefault(stage, []).append(median_ms(function, repeats))
    return {stage: statistics.median(times) for stage, times in stages.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="3 clouds, batch 8, fewer repeats (a smoke test)")
    parser.add_argument("--threads", type=int, default=2, help="torch threads (default: 2)")
    parser.add_argument("--batch", type=int, default=64,
                        help="clouds per batched call (default: 64; 8 with --quick)")
    parser.add_argument("--repeats", type=int,
                        help="timed repeats of each call (default: 3; 1 with --quick)")
    parser.add_argument("--inputs", type=int, default=N_INPUTS,
                        help=f"network inputs per cloud, their consensus answers (default: "
                             f"{N_INPUTS})")
    parser.add_argument("--json", type=Path, help="also write the results to this JSON file")
    add_results_option(parser, "inference")
    args = parser.parse_args()

    with printed_section(args.results, args.section):
        load_before = os.getloadavg()[0]
        torch.set_num_threads(args.threads)
        names = MESHES[:3] if args.quick else MESHES
        batch = 8 if args.quick and args.batch == 64 else args.batch
        repeats = args.repeats or (1 if args.quick else 3)
        clouds = sample_clouds(names)
        predictor = network_predictor("points", device="cpu", n_inputs=args.inputs)
        print(f"torch {torch.__version__}, {args.threads} threads, {os.cpu_count()} CPUs, "
              f"load average {load_before:.2f}")
        print(f"{len(clouds)} clouds of {CLOUD_POINTS} points, {args.inputs} inputs of "
              f"{N_NETWORK_POINTS} points each, network 'points', in process")
        singles = [median_times(functools.partial(predictor, [cloud], [name]), repeats)
                   for name, cloud in clouds.items()]
        single, single_cpu = (statistics.median(times) for times in zip(*singles))
        batch_names = [names[i % len(names)] for i in range(batch)]
        batch_clouds = [clouds[name] for name in batch_names]
        batched, batched_cpu = (ms / batch for ms in median_times(
            lambda: predictor(batch_clouds, batch_names), repeats))
        print(f"  {'single':<32} {single:8.1f} ms per cloud ({single_cpu:.1f} ms CPU)")
        print(f"  {f'batch of {batch}':<32} {batched:8.1f} ms per cloud "
              f"({batched_cpu:.1f} ms CPU)")
        stages = bench_stages(clouds, repeats, args.inputs)
        print("one cloud, by stage (median over the clouds):")
        for stage, ms in stages.items():
            print(f"  {stage:<32} {ms:8.1f} ms")
        load_after = os.getloadavg()[0]
        print(f"load average {load_before:.2f} before, {load_after:.2f} after "
              "(timings mean little on a busy machine)")
        if args.json:
            results = {"threads": args.threads, "cpu_count": os.cpu_count(),
                       "inputs": args.inputs,
                       "torch": torch.__version__, "single_ms": single,
                       "single_cpu_ms": single_cpu, "batch": batch,
                       "batched_ms_per_cloud": batched, "batched_cpu_ms_per_cloud": batched_cpu,
                       "stages_ms": stages,
                       "load_average": [load_before, load_after]}
            args.json.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
