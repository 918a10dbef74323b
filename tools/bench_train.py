"""Training throughput: samples per second of real ``train_model`` epochs against the bare step.

Everything runs in one process, one torch thread, on the same data, so the
ratios hold on a noisy machine:

* **bare step**: forward, backward and Adam on a batch that is already in
  memory, once with plain Adam and once with the fused one: the ceiling;
* **per-item sampling** (``fps_pool=0``): farthest point sampling for every
  input, as ``train_model`` does with ``fps_pool=0``;
* **FPS pool** (``fps_pool=8``, the default): farthest-point subsets made
  once per model, fresh random points and rotations every epoch.

The pool fills as members are first drawn (about 20 epochs for 8 members),
so the bench reports the whole run and its last third (the steady state of a
long run). Only each epoch's training pass is timed (loading and
stepping); validation and checkpoints, which do not grow with the data, are
left out.

Usage::

    python tools/bench_train.py                         # 40 procedural shapes, 30 epochs per set-up
    python tools/bench_train.py --quick                 # a smoke run
    python tools/bench_train.py --dataset reproduction/labels/dataset
    python tools/bench_train.py --results docs/benchmarks.md  # and its section ``train``
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from results_doc import add_results_option, printed_section


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", type=Path,
                        help="a dataset store or build folder (default: build one)")
    parser.add_argument("--epochs", type=int, default=30, help="epochs per set-up")
    parser.add_argument("--models", type=int, default=40, help="training models to use")
    parser.add_argument("--quick", action="store_true", help="tiny sizes, seconds")
    add_results_option(parser, "train")
    return parser.parse_args()


def build(folder: Path, per_category: int, quick: bool) -> Path:
    """A small procedural dataset with the paper's 20000 stored points."""
    from vptoolkit.dataset.builder.options import BuildOptions
    from vptoolkit.dataset.builder.run import build_dataset
    from vptoolkit.points import N_SURFACE_POINTS
    from vptoolkit.settings import MeasureSettings
    from vptoolkit.synthetic import write_collection

    write_collection(folder / "shapes", n_per_category=per_category, seed=0)
    options = BuildOptions(MeasureSettings(views=100 if quick else 200, resolution=64),
                           n_points=4000 if quick else N_SURFACE_POINTS, clean=False)
    result = build_dataset(folder / "shapes", folder / "dataset", options, workers=1)
    return result.path


def bare_steps(dataset: Path, n_points: int, n_fps: int, steps: int, fused: bool) -> float:
    """Samples per second of forward + backward + Adam on one prepared batch of 8."""
    import torch

    from vptoolkit.data import open_dataset
    from vptoolkit.data.torch import ViewpointTorchDataset
    from vptoolkit.learn.labels import label_loss
    from vptoolkit.learn.model import ViewpointNet
    from vptoolkit.learn.train import _collate

    with open_dataset(dataset) as opened:
        items = ViewpointTorchDataset(opened.split("train"), n_points=n_points, n_fps=n_fps)
        batch = _collate([items[i] for i in range(8)])
    model = ViewpointNet(seed=0).train()
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-3, fused=fused)
    for step in range(steps + 1):
        if step == 1:
            started = time.perf_counter()  # the first step warms up
        loss = label_loss("ml", model(batch["points"]), batch).mean()
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
    return 8 * steps / (time.perf_counter() - started)


def epochs_per_second(dataset: Path, out: Path, *, fps_pool: int, epochs: int, models: int,
                      n_points: int, n_fps: int) -> tuple[float, float]:
    """(whole run, last third) training samples per second of ``train_model``.

    Each epoch's training pass (loading, stepping) is timed on its own;
    validation and checkpoint writing, which do not grow with the data, are
    left out.
    """
    from vptoolkit.learn import train as T
    from vptoolkit.learn.options import TrainOptions

    seconds = []
    real_epoch = T._train_epoch

    def timed_epoch(*args, **kwargs):
        started = time.perf_counter()
        result = real_epoch(*args, **kwargs)
        seconds.append(time.perf_counter() - started)
        return result

    T._train_epoch = timed_epoch
    try:
        options = TrainOptions(labels="ml", epochs=epochs, fps_pool=fps_pool, n_points=n_points,
                               n_fps=n_fps, max_models=models, val_rotations=0,
                               val_split="train")
        result = T.train_model(dataset, out, options, threads=1, save_every=epochs, device="cpu",
                               overwrite=True)
    finally:
        T._train_epoch = real_epoch
    tail = seconds[-max(1, len(seconds) // 3):]
    return result.n_train * len(seconds) / sum(seconds), result.n_train * len(tail) / sum(tail)


def main() -> None:
    args = parse_args()
    with printed_section(args.results, args.section):
        import torch

        torch.set_num_threads(1)
        n_points, n_fps = (1024, 256) if args.quick else (4096, 1024)
        epochs = 3 if args.quick else max(3, args.epochs)
        with tempfile.TemporaryDirectory() as scratch:
            root = Path(scratch)
            dataset = args.dataset or build(root, 2 if args.quick else 6, args.quick)
            steps = 3 if args.quick else 20
            plain = bare_steps(dataset, n_points, n_fps, steps, fused=False)
            fused = bare_steps(dataset, n_points, n_fps, steps, fused=True)
            before = epochs_per_second(dataset, root / "before", fps_pool=0, epochs=epochs,
                                       models=args.models, n_points=n_points, n_fps=n_fps)
            after = epochs_per_second(dataset, root / "after", fps_pool=8, epochs=epochs,
                                      models=args.models, n_points=n_points, n_fps=n_fps)
        print(f"training throughput, one thread, {n_points} points ({n_fps} by FPS), "
              "batch 8, samples/s:")
        print(f"  bare step, plain Adam            {plain:8.1f}")
        print(f"  bare step, fused Adam            {fused:8.1f}   ({fused / plain:.2f}x plain)")
        print(f"  train_model, FPS per item        {before[0]:8.1f}   "
              f"({before[0] / fused:.2f} of the bare step)")
        print(f"  train_model, FPS pool, {epochs} epochs {after[0]:8.1f}   "
              f"({after[0] / before[0]:.1f}x FPS per item)")
        print(f"  train_model, FPS pool, last third {after[1]:7.1f}   "
              f"({after[1] / fused:.2f} of the bare step, "
              f"{after[1] / before[1]:.1f}x FPS per item)")


if __name__ == "__main__":
    main()
