"""Commands of the learned predictor: ``train``, ``predict`` and ``evaluate``."""

from __future__ import annotations

import contextlib
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from vptoolkit.checks import check_suffix
from vptoolkit.cli.group import options_named
from vptoolkit.cli.options import (
    DATASET,
    EXISTING,
    MEASURE_NAME,
    PREDICT_MODEL_HELP,
    ExistingPath,
    cache_dir_option,
    device_option,
    max_points_option,
    measures_option,
    parse_point_features,
    seed_option,
    split_option,
)
from vptoolkit.conventions import Split
from vptoolkit.errors import ExistingRunError, InputError
from vptoolkit.files import check_output_folder, output_json
from vptoolkit.learn.options import (
    DEFAULT_FPS_POOL,
    DEFAULT_LABELS,
    DEFAULT_POINT_FEATURES,
    DEFAULT_VAL_SPLIT,
)
from vptoolkit.learn.schedule import PAPER_BATCH_SIZE, PAPER_EPOCHS, PAPER_LR

if TYPE_CHECKING:
    from vptoolkit.data import ViewpointDataset
    from vptoolkit.mesh import Mesh
    from vptoolkit.point_cloud import PointCloud
    from vptoolkit.predictions import Predictions


@click.command()
@click.argument("predictions", type=ExistingPath(exists=True, dir_okay=False, path_type=Path))
@click.option("--dataset", "dataset_path", required=True, type=DATASET,
              help="Dataset built by build-dataset (store, build folder or release folder, "
                   "or a release's URL).")
@split_option("Models to score.")
@click.option("--measure", type=MEASURE_NAME,
              help="The measure of an (N, 3) predictions.npy, or the only one to score.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@click.option("--view-sets", is_flag=True,
              help="PREDICTIONS holds k directions per model, (N, k, 3): report the coverage "
                   "they reach against the greedy k-view set's.")
@cache_dir_option()
def evaluate(predictions: Path, dataset_path: Path | str, split: Split, measure: str | None,
             as_json: bool, view_sets: bool, cache_dir: Path | None) -> None:
    """Score predicted view directions against a dataset.

    PREDICTIONS is a predictions.npz (names, directions (N, M, 3), measures;
    matched by name) or a .npy of shape (N, M, 3) in the dataset's measure
    order, or (N, 3) with --measure, in the split's order. The score of a
    direction is the normalised quality of the nearest sampled view (100 % =
    the best view), per category and measure.

    \b
    Example:
      vptool evaluate predictions.npz --dataset release/ --split test
      vptool evaluate sets.npz --dataset release/ --view-sets
    """
    from vptoolkit.data import open_dataset
    from vptoolkit.evaluate.coverage import evaluate_view_sets
    from vptoolkit.evaluate.scores import evaluate_predictions

    with open_dataset(dataset_path, cache_dir=cache_dir) as dataset:
        if view_sets:
            sets = evaluate_view_sets(dataset, predictions, split=split)
            click.echo(output_json(sets.to_dict(), indent=2) if as_json else sets.format_table())
            return
        report = evaluate_predictions(dataset, predictions, split=split, measure=measure)
    click.echo(output_json(report.to_dict(), indent=2) if as_json else report.format_table())


@click.command()
@click.argument("dataset", type=DATASET)
@click.option("-o", "--output", required=True, type=click.Path(path_type=Path),
              help="Checkpoint: a folder, or a path ending in .safetensors.")
@click.option("--labels", type=click.Choice(["sl", "ml", "gl", "ml+gl", "sr", "dldl"]),
              default=DEFAULT_LABELS, show_default=True, help="Label method.")
@click.option("--epochs", default=PAPER_EPOCHS, show_default=True, type=click.IntRange(1),
              help="Total epochs (the paper's 3000; far fewer already help).")
@click.option("--batch-size", default=PAPER_BATCH_SIZE, show_default=True,
              type=click.IntRange(2))
@click.option("--lr", default=PAPER_LR, show_default=True,
              type=click.FloatRange(min=0, min_open=True),
              help="Initial learning rate (x0.75 fifteen times over the run, as the paper's "
                   "schedule).")
@seed_option(None)
@click.option("--val-split", default=DEFAULT_VAL_SPLIT, show_default=True,
              type=click.Choice(["train", "validation", "val", "test"]),
              help="Split that picks the best epoch.")
@click.option("--per-category", is_flag=True,
              help="One network per category (the paper's set-up) in OUTPUT/<category>/.")
@click.option("--categories", help="Comma-separated categories to train on (default: all).")
@click.option("--fps-pool", default=DEFAULT_FPS_POOL, show_default=True, type=click.IntRange(0),
              help="Farthest-point subsets kept per model (0: sample anew for every input, "
                   "slower).")
@measures_option("Measures to learn, one head each: names the dataset records (VE,NVT,SL), "
                 "'paper' or 'all' [default: every measure the dataset records].", default=None)
@click.option("--point-features", default=",".join(DEFAULT_POINT_FEATURES), show_default=True,
              callback=lambda ctx, param, value: parse_point_features(value),
              help="What each input point carries besides its coordinates, comma-separated: "
                   "face_area, the relative area of the mesh face under it (the tessellation "
                   "VE and VMI weigh); normal, that face's normal; spacing_area, the relative "
                   "area of surface the point stands for, from its 8th neighbour's distance; "
                   "estimated_normal, the normal of the plane through its 8 nearest points; "
                   "or none, coordinates alone (the paper's input). The last two and none "
                   "need no faces: a network trained on them answers bare point clouds.")
@device_option()
@click.option("--threads", type=click.IntRange(1, 1024), help="Torch threads (default: torch's).")
@click.option("--resume", is_flag=True, help="Continue the run stored at --output.")
@cache_dir_option()
def train(dataset: Path | str, output: Path, labels: str, epochs: int, batch_size: int,
          lr: float, seed: int, val_split: str, per_category: bool, categories: str | None,
          fps_pool: int, measures: tuple[str, ...] | None, point_features: tuple[str, ...],
          device: str,
          threads: int | None, resume: bool, cache_dir: Path | None) -> None:
    """Train a viewpoint network on the train split of DATASET (a path or a release's URL).

    Inputs are put in their canonical principal-axis frame, so the network's
    answer turns with the model; each point also carries the relative area of
    the mesh face it lies on (--point-features), found from the stored mesh.
    The network has one head per measure the dataset records (or per
    --measures name), named in its model.json. Keeps
    the checkpoint with the best mean validation score (normalised quality of
    the nearest sampled view, under fixed rotations); the checkpoint is
    safetensors plus a JSON config, never a pickle.

    \b
    Example:
      vptool train release/ -o model.safetensors --labels ml+gl --epochs 200
      vptool train release/ -o per_category/ --per-category --epochs 300
      vptool train release/ -o ve_sl/ --measures VE,SL --epochs 200
    """
    from vptoolkit.data import open_dataset
    from vptoolkit.learn.config import ModelConfig
    from vptoolkit.learn.labels import head_for_method
    from vptoolkit.learn.options import TrainOptions
    from vptoolkit.learn.train import train_model, train_per_category

    most_threads = 8 * (os.cpu_count() or 1)
    if threads is not None and threads > most_threads:
        raise InputError(f"--threads: at most {most_threads} (8 per CPU of this machine), "
                         f"got {threads}")
    run: dict[str, Any] = {
        "resume": resume, "progress": True, "threads": threads, "device": device,
        "command": " ".join(["vptool", *sys.argv[1:]]),
    }
    chosen = [name.strip() for name in categories.split(",")] if categories else None
    try:
        with options_named(val_split="--val-split", dataset_path="DATASET",
                           categories="--categories", measures="--measures"), \
                open_dataset(dataset, cache_dir=cache_dir) as opened:
            options = TrainOptions(labels=labels, epochs=epochs, batch_size=batch_size, lr=lr,
                                   seed=seed, val_split=val_split, categories=chosen,
                                   fps_pool=fps_pool, measures=measures,
                                   architecture=ModelConfig(
                                       head=head_for_method(labels),
                                       point_features=point_features))
            if per_category:
                results = train_per_category(opened, output, options, **run)
            else:
                results = {"": train_model(opened, output, options, **run)}
    except ExistingRunError as error:
        how = ("it has nothing to resume from" if resume
               else "add --resume to continue it")
        raise InputError(f"{output}: already holds a training run; {how}, or give another -o "
                         "(or delete it) to start afresh") from error
    for category, result in results.items():
        scores = ", ".join(f"{m} {100 * v:.1f}%" for m, v in result.best_scores.items())
        click.echo(f"{category + ': ' if category else ''}best epoch {result.best_epoch} of "
                   f"{result.epochs}: {scores}; wrote {result.checkpoint}")


@click.command("predict")
@click.argument("inputs", nargs=-1, type=EXISTING)
@click.option("-m", "--model", default="default", show_default=True, help=PREDICT_MODEL_HELP)
@click.option("--dataset", "dataset_path", type=DATASET,
              help="Predict the models of a dataset (a path or a release's URL).")
@split_option("Split of --dataset.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write names, directions (N, M, 3) and the network's M measures to this "
                   ".npz.")
@seed_option("Seed of the surface sampling and input point choice.")
@click.option("--category",
              help="Category of mesh and point-file inputs, for a per-category model folder.")
# shown, not set: N_INPUTS of vptoolkit.learn.draws, which imports torch (tests/cli/test_learn.py)
@click.option("--inputs", "n_inputs", type=click.IntRange(1, 64), show_default="16",
              help="Network inputs per model; the prediction is the consensus of the network's "
                   "answers to them (1: ask once).")
@click.option("--json", "as_json", is_flag=True,
              help="Print per model its file, name and predictor, and per measure the "
                   "direction and camera pose, with the intrinsics at 1024 px (as best-view "
                   "--json).")
@device_option()
@cache_dir_option()
@max_points_option()
def predict_command(inputs: tuple[Path, ...], model: str, dataset_path: Path | str | None,
                    split: Split, output: Path | None, seed: int, category: str | None,
                    n_inputs: int | None, as_json: bool, device: str,
                    cache_dir: Path | None, max_points: int) -> None:
    """Predict the best view per measure of meshes, point files or a dataset.

    INPUTS are mesh files or point clouds, told apart by content: a PLY, OBJ
    or OFF without faces, .npy ((N, 3) or (N, 6) as written by vptool
    sample), .npz, .xyz, .xyzn, .xyzrgb, .pts, .pcd, .las or .laz.
    Directions come back in each input's own frame, from the
    model centre towards the camera, one per measure the network learnt.
    Without --model the network bundled with vptoolkit predicts (trained on
    real meshes; see docs/results.md); its points carry the area of their
    mesh faces, so it answers meshes and datasets, and point clouds, which
    have no faces, go to the bundled network of coordinates alone (--model
    points; --json names it as the predictor). A network
    answers --inputs draws of each model's points; the prediction is the
    answer most of the others agree with.
    --model unoccluded answers in closed form from normals with occlusion
    ignored (vptoolkit.measures.unoccluded; a mesh's faces, an (N, 6) point file's
    normals, a dataset's stored normals): no network, a few ms, and on real
    meshes often as good as the bundled network (docs/results.md).
    --json prints {"results": [...]}, one record per model in input order:
    file (null for a dataset's model), dataset (null for a file), name,
    predictor (the --model given), and as best-view --json: resolution, up,
    intrinsics and, per measure, the direction and its camera's OpenCV
    camera-to-world pose (4x4, model units, +y at the top of the image);
    progress goes to stderr.

    \b
    Example:
      vptool predict chair.off table.ply
      vptool predict --model points points.npy
      vptool predict --model unoccluded scan.npy
      vptool predict -m model.safetensors --dataset release/ --split test -o test.npz
      vptool predict mug.obj --json
    """
    from vptoolkit.data import open_dataset
    from vptoolkit.predictors import resolve_predictor

    predictor = resolve_predictor(model, seed=seed, category=category, device=device,
                                  n_inputs=n_inputs, progress=True, max_points=max_points)
    if output is not None:
        check_suffix(output, ".npz")
        check_output_folder(output, "--output")
    if not inputs and dataset_path is None:
        raise InputError("inputs: give mesh or point files, or --dataset")
    with contextlib.ExitStack() as stack, options_named(category_="--category"):
        sources: list[Path | ViewpointDataset] = list(inputs)
        if dataset_path is not None:
            sources.append(stack.enter_context(open_dataset(dataset_path, cache_dir=cache_dir)))
        predictions = predictor(sources, split=split)
        records = (_answer_records(sources, predictions, split, model, dataset_path, max_points)
                   if as_json else None)
    if output is not None:
        predictions.save_npz(output)
    if records is not None:
        click.echo(output_json({"results": records}, indent=2))
        return
    names, directions, measures = predictions.names, predictions.directions, predictions.measures
    for name, answer in zip(names[:10], directions[:10]):
        cells = "  ".join(f"{m} ({x:+.2f}, {y:+.2f}, {z:+.2f})"
                          for m, (x, y, z) in zip(measures, answer))
        click.echo(f"{name}: {cells}")
    if len(names) > 10:
        click.echo(f"... and {len(names) - 10} more")
    if output is not None:
        click.echo(f"wrote {output} ({len(names)} models)")


def _answer_records(sources: list[Path | ViewpointDataset], predictions: Predictions,
                    split: Split, predictor: str,
                    dataset_path: Path | str | None, max_points: int) -> list[dict[str, Any]]:
    """The ``predict --json`` record of every model of ``predictions``, in their order
    (``dataset_path``: the ``--dataset`` given, which names a stored model's dataset;
    ``max_points``: the ``--max-points`` the models were read with).

    Each model is read again for its bounding box, which places the cameras
    (:meth:`vptoolkit.camera.Camera.look_at` at ``RESOLUTION`` pixels); the
    rest is :func:`vptoolkit.best_view.answer.answer_record`.
    """
    from vptoolkit.best_view.answer import answer_record
    from vptoolkit.camera import Camera
    from vptoolkit.conventions import RESOLUTION
    from vptoolkit.inputs import open_inputs

    camera = Camera()
    records: list[dict[str, Any]] = []
    with open_inputs(sources, split=split, max_points=max_points) as models:
        by_name = {source.name: source for source in models}  # names are unique (claim_name)
        for name, directions in zip(predictions.names, predictions.directions, strict=True):
            source = by_name[name]
            model = source.model()
            poses = camera.look_at(model, directions, resolution=RESOLUTION)
            records.append({"file": source.origin if source.kind == "file" else None,
                            "dataset": None if source.kind == "file" else str(dataset_path),
                            "name": name, "predictor": _answered_by(predictor, model),
                            **answer_record(predictions.measures, directions, poses)})
    return records


COMMANDS = (train, predict_command, evaluate)
"""The commands this module adds to ``vptool``."""


def _answered_by(predictor: str, model: Mesh | PointCloud) -> str:
    """The ``--model`` that answered ``model``: a bundled network that reads face areas
    hands a point cloud to its network of coordinates
    (:data:`~vptoolkit.learn.checkpoint.CLOUD_MODELS`)."""
    from vptoolkit.learn.checkpoint import CLOUD_MODELS
    from vptoolkit.point_cloud import PointCloud

    return CLOUD_MODELS.get(predictor, predictor) if isinstance(model, PointCloud) else predictor
