"""Reproduce the paper's table 2 (label methods) on procedural shapes.

ModelNet40 cannot be shipped, so this builds a benchmark from
:mod:`vptoolkit.synthetic` (eight category-like shape families with random
proportions and symmetries), trains every label method (SL, ML, GL, ML+GL and
the baselines SR and DLDL) with the same budget, scores each on the test split
the authors' way (normalised quality of the nearest sampled view, in %), and
writes the table with three non-learned rows beside it: a random view, a
PCA-axis heuristic and the oracle (the dataset's own best views).

The result replaces the section between ``<!-- labels:start -->`` and
``<!-- labels:end -->`` of ``docs/results.md``; every number comes from the
run. Every stage resumes: the dataset build and each training pick up where
an interrupted run stopped. With ``--export-pretrained DIR`` the ML+GL
checkpoint is also saved there in float16 with this command recorded in its
JSON: that is how ``vptoolkit/learn/pretrained`` (``--model default``) is made.

Usage::

    python tools/reproduce_labels.py                 # the default budget (about 2 h on 2 cores)
    python tools/reproduce_labels.py --quick         # tiny sizes, minutes; writes nothing to docs/
    python tools/reproduce_labels.py --export-pretrained vptoolkit/learn/pretrained
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from vptoolkit.conventions import MEASURES
from vptoolkit.data import open_dataset
from vptoolkit.dataset.build import build_dataset
from vptoolkit.evaluate import oracle_directions, pca_directions, random_directions, score_directions
from vptoolkit.learn.predict import predict
from vptoolkit.learn.train import train_model
from vptoolkit.synthetic import CATEGORIES, write_collection

METHODS = ("sl", "ml", "gl", "ml+gl", "sr", "dldl")
LABELS = {"sl": "SL", "ml": "ML", "gl": "GL", "ml+gl": "ML+GL (ours)", "sr": "SR", "dldl": "DLDL"}
# The paper's table 2: mean over its eight ModelNet40 categories (%), VE, VR, VKL, VMI.
PAPER = {
    "SL": (62.4, 71.0, 80.7, 83.0), "SR": (63.1, 69.8, 80.6, 80.1),
    "DLDL": (58.7, 66.6, 77.9, 77.9), "ML+GL (ours)": (79.3, 78.2, 91.2, 92.5),
    "ML": (70.1, 72.1, 82.6, 82.1), "GL": (74.2, 75.1, 89.3, 87.7),
}
START, END = "<!-- labels:start -->", "<!-- labels:end -->"


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("reproduction/labels"),
                        help="working folder for shapes, dataset and models")
    parser.add_argument("--per-category", type=int, default=50, help="shapes per category")
    parser.add_argument("--epochs", type=int, default=30, help="epochs per method (same for all)")
    parser.add_argument("--resolution", type=int, default=256, help="px of the measures")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--workers", type=int, default=2, help="dataset build processes")
    parser.add_argument("--results", type=Path, default=Path("docs/results.md"))
    parser.add_argument("--quick", action="store_true", help="tiny sizes for a smoke test")
    parser.add_argument("--export-pretrained", type=Path,
                        help="also save the ML+GL checkpoint here in float16 "
                             "(the package's is vptoolkit/learn/pretrained)")
    parser.add_argument("--pretrained-epochs", type=int,
                        help="train the exported ML+GL network this many epochs instead "
                             "(in OUT/models/ml_gl_<N>e; default: --epochs, the table's run)")
    return parser.parse_args()


@dataclass(frozen=True)
class LabelSizes:
    """Sizes of one table-2 run; the defaults are the full run's.

    ``n_views`` Fibonacci views at ``resolution`` px per model, ``n_points``
    stored surface points, ``clean`` runs the paper's cleaning, and every
    method trains ``epochs`` epochs on ``train_points`` input points, the
    first ``train_fps`` of them by farthest point sampling.
    """

    per_category: int = 50
    epochs: int = 30
    resolution: int = 256
    n_views: int = 1000
    n_points: int = 20000
    clean: bool = True
    train_points: int = 4096
    train_fps: int = 1024


QUICK = LabelSizes(per_category=3, epochs=2, resolution=64, n_views=100, n_points=2000,
                   clean=False, train_points=512, train_fps=128)
"""The ``--quick`` sizes: a smoke test of minutes."""


def main() -> None:
    args = parse_args()
    sizes = QUICK if args.quick else LabelSizes(
        per_category=args.per_category, epochs=args.epochs, resolution=args.resolution)
    command = "python tools/reproduce_labels.py " + shlex.join(sys.argv[1:])
    table = run(args.out, sizes, methods=args.methods.split(","), workers=args.workers,
                command=command.strip())
    print(table)
    if not args.quick:
        write_section(args.results, table)
    if args.export_pretrained is not None:
        checkpoint = args.out / "models" / "ml_gl"
        epochs = args.pretrained_epochs or sizes.epochs
        if epochs != sizes.epochs:
            checkpoint = train_model(
                args.out / "dataset", args.out / "models" / f"ml_gl_{epochs}e", labels="ml+gl",
                epochs=epochs, seed=0, resume=True, progress=True, threads=1, workers=1,
                n_points=sizes.train_points, n_fps=sizes.train_fps,
            ).checkpoint
        export_pretrained(checkpoint, args.export_pretrained, command.strip(), sizes)


def export_pretrained(checkpoint: Path, target: Path, command: str, sizes: LabelSizes) -> None:
    """Save a trained checkpoint in float16 with the command and data that made it."""
    from vptoolkit.learn.model import load_model, save_model

    model, config = load_model(checkpoint)
    config["pretrained"] = {
        "command": command,
        "data": f"vptoolkit.synthetic, {len(CATEGORIES)} categories x {sizes.per_category} "
                f"shapes (seed 0), {sizes.n_views} views at {sizes.resolution} px, "
                f"{'cleaned' if sizes.clean else 'not cleaned'}",
        "results": "docs/results.md",
    }
    weights, _ = save_model(model, target, metadata=config, half=True)
    print(f"exported {checkpoint} to {target} ({weights.stat().st_size / 2**20:.1f} MiB)")


def run(out: Path, sizes: LabelSizes = LabelSizes(), *, methods: Sequence[str] = METHODS,
        workers: int = 2, command: str = "python tools/reproduce_labels.py") -> str:
    """Build the benchmark, train every method, score it and return the markdown section.

    Shapes go to ``out/shapes``, the dataset to ``out/dataset``, checkpoints to
    ``out/models/<method>`` (``+`` becomes ``_``, so ML+GL is ``models/ml_gl``)
    and the numbers to ``out/table2.json``. Every stage resumes. When the
    dataset's ``val`` split is empty (tiny runs), training picks its best
    checkpoint on ``train`` instead.
    """
    started = time.perf_counter()
    shapes, dataset_dir = out / "shapes", out / "dataset"
    if not shapes.exists():
        write_collection(shapes, n_per_category=sizes.per_category, seed=0)
    built = build_dataset(shapes, dataset_dir, n_views=sizes.n_views,
                          resolution=sizes.resolution, n_points=sizes.n_points,
                          clean=sizes.clean, workers=workers, split_seed=0,
                          progress=True)
    with open_dataset(built.path) as dataset:
        val_split = "val" if len(dataset.split("val")) else "train"
    rows: dict[str, np.ndarray] = {}
    timings: dict[str, float] = {}
    n_parameters = {}
    for method in methods:
        trained = train_model(
            built.path, out / "models" / method.replace("+", "_"), labels=method,
            epochs=sizes.epochs, seed=0, resume=True, progress=True, threads=1, workers=1,
            n_points=sizes.train_points, n_fps=sizes.train_fps, val_split=val_split,
        )
        timings[LABELS[method]] = sum(epoch["seconds"] for epoch in trained.history)
        n_parameters[LABELS[method]] = trained.n_parameters
        predictions = predict(trained.checkpoint, built.path, split="test", threads=1)
        with open_dataset(built.path) as dataset:
            test = dataset.split("test")
            order = [predictions.names.index(name) for name in test.names]
            report = score_directions(test, predictions.directions[order])
        rows[LABELS[method]] = report.mean
    with open_dataset(built.path) as dataset:
        test = dataset.split("test")
        points = [test[i]["points"] for i in range(len(test))]
        baselines = {
            "random view": random_directions(len(test), seed=0),
            "PCA axis": pca_directions(points),
            "oracle": oracle_directions(test),
        }
        for label, directions in baselines.items():
            rows[label] = score_directions(test, directions).mean
        split_sizes = {split: len(dataset.split(split)) for split in ("train", "val", "test")}
    seconds = time.perf_counter() - started
    table = render(rows, timings, n_parameters, split_sizes, sizes, command, seconds)
    (out / "table2.json").write_text(json.dumps(
        {"rows": {k: list(map(float, v)) for k, v in rows.items()}, "train_seconds": timings,
         "sizes": split_sizes, "seconds": seconds}, indent=2))
    return table


def format_seconds(seconds: float) -> str:
    """A wall time in the largest fitting unit: ``42 s``, ``12.5 min`` or ``3.1 h``."""
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def machine() -> str:
    """One line naming this machine: platform, processor and CPU count."""
    return (f"{platform.platform(terse=True)}, {platform.processor() or platform.machine()}, "
            f"{os.cpu_count()} CPUs, no GPU used")


def render(rows, timings, n_parameters, split_sizes, sizes: LabelSizes, command: str,
           seconds: float) -> str:
    lines = [
        "## Table 2: label methods on procedural shapes",
        "",
        f"Command: `{command}`; {datetime.now(timezone.utc):%Y-%m-%d}, "
        f"{machine()}; wall time {format_seconds(seconds)}.",
        "",
        f"Dataset: `vptoolkit.synthetic`, 8 categories x {sizes.per_category} shapes "
        f"(train {split_sizes['train']}, val {split_sizes['val']}, test {split_sizes['test']}), "
        f"{'cleaned' if sizes.clean else 'not cleaned'}, {sizes.n_points} points, "
        f"{sizes.n_views} views, measures at {sizes.resolution} px. Every method trains "
        f"{sizes.epochs} epochs with the paper's other settings (Adam, batch 8, lr 0.001, "
        f"x0.75 every 200 epochs, {sizes.train_points} input points, random rotations); "
        "the paper trains 3000 epochs on ModelNet40. Scores: mean over categories of the "
        "normalised quality of the nearest sampled view on the test split, in %.",
        "",
        "| method | " + " | ".join(MEASURES) + " | train time | paper (ModelNet40) |",
        "|---|" + "---:|" * len(MEASURES) + "---:|---|",
    ]
    for label, scores in rows.items():
        paper = " / ".join(f"{v:.1f}" for v in PAPER[label]) if label in PAPER else ""
        train = format_seconds(timings[label]) if label in timings else ""
        lines.append(f"| {label} | " + " | ".join(f"{v:.1f}" for v in scores) +
                     f" | {train} | {paper} |")
    learned = [label for label in rows if label in PAPER]
    if learned:
        best = max(learned, key=lambda k: rows[k].mean())
        lines += ["", f"Best learned method by mean over the measures: {best}. "
                  f"Network parameters: {next(iter(n_parameters.values()))}."]
    return "\n".join(lines)


def write_section(path: Path, table: str, *, start: str = START, end: str = END) -> None:
    """Replace the text between the ``start`` and ``end`` markers of ``path`` by ``table``.

    The file (and its folder) is created if missing; a section not yet in it
    is appended, so several scripts can each own their sections of one file.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    text = path.read_text() if path.exists() else "# Results\n\n"
    block = f"{start}\n{table}\n{end}"
    if start in text and end in text:
        text = text[: text.index(start)] + block + text[text.index(end) + len(end):]
    else:
        text = text.rstrip() + "\n\n" + block + "\n"
    path.write_text(text)


if __name__ == "__main__":
    main()
