"""Train a viewpoint network on a dataset store.

:func:`train_model` follows the paper's recipe (Schelling et al. 2021,
section 4.3): Adam, batch size 8, learning rate 0.001 multiplied by 0.75
every 200 of 3000 epochs (for another length the step scales with it, so
every run decays 15 times), ML labels for the first half and GL labels for
the second (``labels="ml+gl"``), inputs of 4096 points (1024 by farthest
point sampling plus 3072 random) under a random rotation per model and epoch
(:class:`vptoolkit.data.torch.ViewpointTorchDataset`; views rotate with the
points, so labels stay in the input frame). The network puts every input in
its canonical principal-axis frame (:mod:`vptoolkit.learn.frame`).

Throughput: farthest point sampling dominates the cost of an input, so each
model keeps a pool of ``fps_pool`` farthest-point subsets made once, and
every epoch draws one of them plus fresh random points and a fresh rotation;
models stay in memory; Adam is the fused implementation; the resumable state
is written every ``save_every`` epochs and at the end.
``tools/bench_train.py`` measures the effect.

After every epoch the network predicts the validation models under the
rotated protocol (:mod:`vptoolkit.evaluate.protocol`): each model under
``val_rotations`` fixed rotations seeded by its name, eval mode, the same
input points as :func:`vptoolkit.learn.predict.predict` would choose; each
prediction scores the normalised quality of its nearest sampled view
(:func:`vptoolkit.learn.labels.nearest_view_quality`). The checkpoint with
the best mean over the measures is kept.

Measures
    The network has one head per measure of the options' ``measures``
    (default: every measure the dataset records, its ``measures``
    attribute), in that order; its labels are those columns of the stored
    normalised quality (1 = best view, whichever way the raw measure is
    better) and those entries of the stored best views. ``model.json``
    names them (``measures``, and the architecture's), and so do the
    validation scores and the history. The recorded options keep
    ``measures`` as given (None: the dataset's), so a resumed run compares
    the names its architecture learnt.

The options that define a run are one value,
:class:`vptoolkit.learn.options.TrainOptions`, recorded in the files below;
how a call runs (device, threads, workers, ``save_every``, progress) are
keywords of :func:`train_model`.

The options' ``categories`` restrict a run to some categories; :func:`train_per_category`
trains the paper's set-up, one network per category, into one folder that
:func:`vptoolkit.learn.predict.predict` routes by category.

Files (``OUT`` a folder, or ``OUT.safetensors`` naming the weights file)

==============================  ===========================================
``model.safetensors``           best weights (safetensors)
``model.json``                  its configuration: architecture, label
                                method, measures, input size, training
                                options and command, epochs, best score,
                                toolkit and torch versions
``model.last.safetensors``      the state after the last saved epoch
                                (every ``save_every`` and the last):
                                weights and Adam moments
``model.last.json``             epoch, Adam hyper-parameters, history,
                                best score so far, options
==============================  ===========================================

(``<stem>.json``, ``<stem>.last.*`` beside ``OUT.safetensors``.) Nothing is
pickled; every file is written atomically.

Determinism
    The initial weights, the order of the models in each epoch, the dropout
    masks and the augmentations are drawn from generators seeded with
    ``(seed, epoch, purpose)`` or ``(seed, epoch, model name)``, never from
    the global random state, and the learning rate is a function of the
    epoch. So the same command gives the same weights (on the same machine,
    device and thread count), and ``resume=True`` continues a stopped run
    from its last saved epoch exactly as an uninterrupted run would.

The paper's settings and the learning-rate schedule are in
:mod:`vptoolkit.learn.schedule`, the options in :mod:`vptoolkit.learn.options`,
the choice of models in :mod:`vptoolkit.learn.splits` and the validation in
:mod:`vptoolkit.learn.validation`.
"""

from __future__ import annotations

import logging
import math
import os
import platform
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

import numpy as np

from vptoolkit.checks import check_int
from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.errors import ArgumentError, ExistingRunError, InputError
from vptoolkit.files import check_path_part, write_json_atomic
from vptoolkit.learn.checkpoint import checkpoint_paths
from vptoolkit.learn.labels import label_loss, label_phase
from vptoolkit.learn.model import (
    ViewpointNet,
    count_parameters,
    resolve_device,
    save_model,
    torch_threads,
)
from vptoolkit.learn.options import TrainOptions
from vptoolkit.learn.predict import CATEGORY_MODELS_FORMAT
from vptoolkit.learn.record import training_record, update_best_record
from vptoolkit.learn.schedule import learning_rate
from vptoolkit.learn.splits import select_categories, select_models
from vptoolkit.learn.state import (
    load_state,
    save_state,
    state_paths,
    toolkit_version,
)
from vptoolkit.learn.validation import validation_inputs, validation_scores
from vptoolkit.optional import require

if TYPE_CHECKING:
    import torch
    from torch import Tensor
else:
    torch = require("torch", extra="learn")
    Tensor = torch.Tensor

__all__ = [
    "DEFAULT_SAVE_EVERY",
    "TrainResult",
    "train_model",
    "train_per_category",
]

_log = logging.getLogger(__name__)

_SEED_SHUFFLE = 1
_SEED_DROPOUT = 2

DEFAULT_SAVE_EVERY: Final = 10
"""Epochs between two writes of the resumable state (the last epoch is always written)."""


@dataclass(frozen=True)
class TrainResult:
    """What :func:`train_model` did.

    Attributes
    ----------
    checkpoint : Path
        Best weights (``*.safetensors``); load with
        :func:`vptoolkit.learn.model.load_model`.
    config_path : Path
        Its JSON configuration.
    state_path : Path
        Resumable state after the last epoch (``*.last.safetensors``).
    labels : str
        Label method.
    epochs : int
        Epochs completed (including those of a resumed run).
    best_epoch : int
        Epoch (1-based) of the best checkpoint.
    best_score : float
        Its mean validation score over the measures, in [0, 1].
    best_scores : dict of str to float
        Its validation score per measure, in the network's head order.
    history : tuple of dict
        Per epoch: ``epoch`` (1-based), ``phase`` (loss used), ``lr``,
        ``loss`` (mean training loss), ``val_scores`` (per measure),
        ``val_score`` (mean) and ``seconds``.
    n_train, n_val : int
        Models trained and validated on.
    n_parameters : int
        Learned parameters of the network.
    seconds : float
        Wall time of this call.
    """

    checkpoint: Path
    config_path: Path
    state_path: Path
    labels: str
    epochs: int
    best_epoch: int
    best_score: float
    best_scores: dict[str, float]
    history: tuple[dict[str, Any], ...]
    n_train: int
    n_val: int
    n_parameters: int
    seconds: float


def _seed(*keys: int) -> int:
    sequence = np.random.SeedSequence([int(key) for key in keys])
    return int(sequence.generate_state(1, np.uint64)[0] >> 1)


def _generator(*keys: int, device: torch.device | str = "cpu") -> torch.Generator:
    return torch.Generator(device=device).manual_seed(_seed(*keys))


def _measure_columns(dataset: ViewpointDataset,
                     options: TrainOptions) -> tuple[TrainOptions, tuple[int, ...]]:
    """The options with their measures filled in, and those measures' columns in the dataset.

    ``options.measures`` None stands for every measure the dataset records.

    Raises
    ------
    InputError
        ``measures: ...`` for a name the dataset does not record; for a
        default that would learn a recorded name the registry does not know.
    """
    from vptoolkit.measures.registry import all_measures

    recorded = tuple(dataset.measures)
    names = recorded if options.measures is None else tuple(options.measures)
    unknown = [name for name in names if name not in all_measures()]
    if unknown:  # only the dataset's own names can be unknown here: options are checked
        raise InputError(f"{dataset.path.name}: records {', '.join(map(repr, unknown))}, which "
                         "this vptoolkit does not know as measures; name the ones to learn")
    missing = [name for name in names if name not in recorded]
    if missing:
        raise ArgumentError(f"{{argument}}: {dataset.path.name} does not record "
                            f"{', '.join(missing)} (it records {', '.join(recorded)})", "measures")
    return replace(options, measures=names), tuple(recorded.index(name) for name in names)


@dataclass(frozen=True)
class _TakeMeasures:
    """A training item's labels for some of the dataset's measures, in the network's order.

    ``quality`` ``(V, M_all)`` keeps the columns ``columns``; ``best_views``
    ``(M_all, 3)`` and ``best_index`` ``(M_all,)`` keep those rows. A class,
    not a closure, so that data-loading workers can unpickle it.
    """

    columns: tuple[int, ...]

    def __call__(self, item: dict[str, Any]) -> dict[str, Any]:
        index = list(self.columns)
        return {**item, "quality": item["quality"][:, index],
                "best_views": item["best_views"][index], "best_index": item["best_index"][index]}


def _collate(items: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    batch: dict[str, Any] = {"name": [item["name"] for item in items]}
    for key in ("points", "views", "quality", "best_views"):
        batch[key] = torch.stack([item[key] for item in items])
    return batch


def _batches(n_models: int, batch_size: int, generator: torch.Generator) -> list[list[int]]:
    order = torch.randperm(n_models, generator=generator).tolist()
    batches = [order[start : start + batch_size] for start in range(0, n_models, batch_size)]
    if len(batches[-1]) == 1 and n_models > 1:
        batches.pop()  # batch norm needs two samples; this model comes back in other epochs
    return batches


def train_model(
    dataset_path: str | os.PathLike[str] | ViewpointDataset,
    output: str | os.PathLike[str],
    options: TrainOptions | None = None,
    *,
    resume: bool = False,
    overwrite: bool = False,
    progress: bool = False,
    save_every: int = DEFAULT_SAVE_EVERY,
    workers: int = 0,
    threads: int | None = None,
    device: str = "auto",
    command: str | None = None,
) -> TrainResult:
    """Train a viewpoint network and keep the checkpoint with the best validation score.

    ``options`` say what the run learns, and are recorded; the keywords say
    how this call runs (where, on how many threads, how often it saves),
    which does not change the result, so a run may resume with others.

    Parameters
    ----------
    dataset_path : path-like or ViewpointDataset
        A dataset store, build/release folder or release URL, or a dataset
        opened by :func:`vptoolkit.data.open_dataset` (left open); trains on
        its ``train`` split, whose models need at least ``options.n_fps``
        stored points each.
    output : path-like
        Folder for ``model.safetensors`` and friends, or a ``*.safetensors``
        path (see the module docstring).
    options : TrainOptions, optional
        Label method, schedule, seed, models, inputs and architecture
        (default: ``TrainOptions()``, the paper's recipe).
    resume : bool
        Continue from ``<stem>.last.*`` if present, else start afresh
        (default: False). The recorded options must equal ``options`` but
        for ``epochs``, which may grow.
    overwrite : bool
        Replace an existing run in ``output`` instead of refusing (default: False).
    progress : bool
        Show a tqdm bar with the loss and validation score (default: False).
    save_every : int
        Write the resumable state every this many epochs, and after the
        last (default: :data:`DEFAULT_SAVE_EVERY`).
    workers : int
        Data-loading worker processes (default: 0, in this process).
    threads : int, optional
        Torch threads during the call, restored afterwards (default: None,
        leave torch's setting). On a busy machine 1 can be much faster than
        2, whose threads wait on each other; to use several cores, run
        several single-threaded trainings side by side.
    device : {"auto", "cpu", "cuda"}
        Where the network runs (default: "auto", CUDA when torch sees it).
        Nothing needs a GPU.
    command : str, optional
        The command line to record in the configuration (the CLI passes it).

    Returns
    -------
    TrainResult

    Raises
    ------
    InputError
        On invalid keywords, an empty split, a measure the dataset does not
        record (or one the registry does not know) or a resumed run with
        other options.
    ExistingRunError
        If ``output`` holds a run and neither ``resume`` (with a state to
        resume from) nor ``overwrite`` is given.
    CheckpointError
        If the state to resume from does not fit the network.
    """
    if options is None:
        options = TrainOptions()
    elif not isinstance(options, TrainOptions):
        raise InputError(f"options: expected TrainOptions, got {type(options).__name__}")
    save_every = check_int(save_every, "save_every", minimum=1)
    workers = check_int(workers, "workers", minimum=0)
    where = resolve_device(device)
    with torch_threads(threads):
        return _train(dataset_path, output, options, resume=resume, overwrite=overwrite,
                      progress=progress, save_every=save_every, workers=workers, device=where,
                      command=command)


def _train(dataset_path: str | os.PathLike[str] | ViewpointDataset,
           output: str | os.PathLike[str],
           options: TrainOptions, *, resume: bool, overwrite: bool, progress: bool,
           save_every: int, workers: int, device: torch.device,
           command: str | None) -> TrainResult:
    started = time.perf_counter()
    epochs, labels, seed = options.epochs, options.labels, options.seed
    weights_path, config_path = checkpoint_paths(output)
    last_weights, last_json = state_paths(output)
    from vptoolkit.data.torch import ViewpointTorchDataset

    is_owner = not isinstance(dataset_path, ViewpointDataset)
    dataset = (dataset_path if isinstance(dataset_path, ViewpointDataset)
               else open_dataset(dataset_path))
    try:
        _check_point_count(dataset, options.n_fps)
        chosen = select_categories(dataset, options.categories)
        # Recorded as given (None: the dataset's); the architecture names the heads learnt.
        given = options.to_dict()["measures"]
        options, columns = _measure_columns(dataset, options)
        config = options.model_config
        arguments = {
            "dataset_path": str(dataset_path if is_owner else dataset.path),
            "output": str(output),
            **options.to_dict(), "measures": given,
            "save_every": save_every, "workers": workers, "device": str(device),
        }
        train_set, n_train = select_models(dataset, "train", chosen, options.max_models,
                                           "dataset_path")
        val_set, n_val = select_models(dataset, options.val_split, chosen, options.max_models,
                                       "val_split")
        if n_train < 2:
            raise ArgumentError(f"{{argument}}: {dataset.path.name} has {n_train} training "
                                "model; need at least 2", "dataset_path")
        is_resuming = bool(resume) and last_json.exists()
        if not is_resuming and not overwrite and (weights_path.exists() or last_json.exists()):
            hint = (f"it has no resumable state ({last_json.name}); pass overwrite=True to "
                    "start afresh" if resume
                    else "pass resume=True to continue it or overwrite=True to replace it")
            raise ExistingRunError(f"{weights_path.parent}: already holds a training run "
                                   f"({weights_path.name}); {hint}")
        every = columns == tuple(range(len(dataset.measures)))
        train_data = ViewpointTorchDataset(train_set, n_points=options.n_points,
                                           n_fps=options.n_fps, rotate=options.rotate, seed=seed,
                                           fps_pool=options.fps_pool,
                                           point_features=config.point_features,
                                           transform=None if every else _TakeMeasures(columns))
        validation = validation_inputs(val_set, n_val, n_points=options.n_points,
                                       n_fps=options.n_fps, seed=seed,
                                       rotations=options.val_rotations, device=device,
                                       columns=columns, point_features=config.point_features)

        model = ViewpointNet(config, seed=_seed(seed, 0)).to(device)
        optimizer = torch.optim.Adam(model.parameters(), lr=options.lr, fused=True)
        history: list[dict[str, Any]] = []
        best: dict[str, Any] = {"epoch": 0, "score": -math.inf, "scores": {}}
        start_epoch = 0
        if is_resuming:
            start_epoch, history, best = load_state(model, optimizer, last_weights, last_json,
                                                    options)
        metadata_base = {
            "labels": labels,
            "input": {"n_points": options.n_points, "n_fps": options.n_fps},
            "categories": chosen,
            "toolkit_version": toolkit_version(),
            "torch_version": torch.__version__,
            "python_version": platform.python_version(),
        }
        weights_path.parent.mkdir(parents=True, exist_ok=True)
        tqdm = require("tqdm").tqdm
        bar = tqdm(total=epochs, initial=start_epoch, disable=not progress,
                   desc=f"train {labels}", unit="epoch", dynamic_ncols=True)
        try:
            for epoch in range(start_epoch, epochs):
                epoch_started = time.perf_counter()
                phase = label_phase(labels, epoch, epochs)
                rate = learning_rate(epoch, lr=options.lr, lr_decay=options.lr_decay,
                                     lr_step=options.decay_step)
                for group in optimizer.param_groups:
                    group["lr"] = rate
                loss = _train_epoch(model, optimizer, train_data, n_train, phase=phase,
                                    epoch=epoch, seed=seed, batch_size=options.batch_size,
                                    workers=workers, device=device)
                scores = validation_scores(model, validation)
                score = float(scores.mean())
                entry = {
                    "epoch": epoch + 1, "phase": phase, "lr": rate, "loss": loss,
                    "val_scores": {name: float(value)
                                   for name, value in zip(config.measures, scores.tolist())},
                    "val_score": score, "seconds": time.perf_counter() - epoch_started,
                }
                history.append(entry)
                if score > best["score"]:
                    best = {"epoch": epoch + 1, "score": score, "scores": entry["val_scores"]}
                    training = training_record(arguments, command, dataset, n_train, n_val, epochs,
                                                epoch + 1, best)
                    save_model(model, weights_path,
                               metadata={**metadata_base, "training": training})
                if (epoch + 1) % save_every == 0 or epoch + 1 == epochs:
                    save_state(model, optimizer, last_weights, last_json, arguments=arguments,
                               epoch=epoch + 1, history=history, best=best)
                _log.info("epoch %d/%d %s loss %.4f val %.4f", epoch + 1, epochs, phase, loss,
                          score)
                bar.set_postfix(loss=f"{loss:.4f}", val=f"{score:.3f}", best=f"{best['score']:.3f}")
                bar.update(1)
        finally:
            bar.close()
        update_best_record(config_path, arguments, command, dataset, n_train, n_val, epochs,
                            history, best)
        return TrainResult(
            checkpoint=weights_path, config_path=config_path, state_path=last_weights,
            labels=labels,
            epochs=len(history), best_epoch=int(best["epoch"]), best_score=float(best["score"]),
            best_scores={name: best["scores"][name] for name in config.measures
                         if name in best["scores"]},  # head order (JSON sorts a resumed state's)
            history=tuple(history), n_train=n_train,
            n_val=n_val, n_parameters=count_parameters(model),
            seconds=time.perf_counter() - started,
        )
    finally:
        if is_owner:
            dataset.close()


def _check_point_count(dataset: ViewpointDataset, n_fps: int) -> None:
    """Refuse a dataset whose models have fewer stored points than a network input's
    farthest-point part (``TrainOptions.n_fps``, :data:`~vptoolkit.points.N_FPS_POINTS`
    by default)."""
    from vptoolkit.points import N_SURFACE_POINTS

    n_points = int(dataset.attrs["n_points"])
    if n_points < n_fps:
        raise InputError(f"{dataset.path}: models have {n_points} points; training needs at "
                         f"least {n_fps} per model (build with --points {n_fps} "
                         f"or more; the paper uses {N_SURFACE_POINTS})")


def _trained_categories(dataset: ViewpointDataset, options: TrainOptions) -> list[str]:
    """The categories of a per-category run: those asked for, else every one with training
    models, sorted."""
    chosen = select_categories(dataset, options.categories)
    return list(chosen) if chosen is not None else sorted(set(dataset.split("train").categories))


def train_per_category(
    dataset_path: str | os.PathLike[str] | ViewpointDataset,
    output: str | os.PathLike[str],
    options: TrainOptions | None = None,
    **run: Any,
) -> dict[str, TrainResult]:
    """Train one network per category, the paper's set-up, into one folder.

    Each category's run is :func:`train_model` with the options restricted
    to that category (``categories=(name,)``) into ``output/<category>/``
    (a category that cannot be a folder name is refused,
    :func:`~vptoolkit.files.check_path_part`);
    ``output/categories.json`` indexes them (``format``, ``categories``:
    name to checkpoint folder); categories an earlier run into the same
    folder listed stay listed. Give that folder to
    :func:`vptoolkit.learn.predict.predict`, which routes each model to its
    category's network.

    Parameters
    ----------
    dataset_path, output : path-like
        As for :func:`train_model` (``dataset_path`` may be an open dataset);
        ``output`` is a folder.
    options : TrainOptions, optional
        The options of every category's run (default: ``TrainOptions()``);
        their ``categories`` are the categories to train (default: every
        category with training models).
    **run
        :func:`train_model`'s keywords (``resume``, ``progress``,
        ``device``...), the same for every category.

    Returns
    -------
    results : dict of str to TrainResult
        By category, sorted.
    """
    if options is None:
        options = TrainOptions()
    folder = Path(output)
    if folder.suffix == ".safetensors":
        raise InputError(f"{folder}: per-category training writes a folder, not one "
                         ".safetensors file")
    if isinstance(dataset_path, ViewpointDataset):
        where, names = dataset_path.path, _trained_categories(dataset_path, options)
    else:
        with open_dataset(dataset_path) as dataset:
            where, names = Path(dataset_path), _trained_categories(dataset, options)
    folders = {name: check_path_part(name, f"{where}: category") for name in names}
    index = _category_index(folder)
    results = {}
    for name, part in folders.items():
        results[name] = train_model(dataset_path, folder / part,
                                    replace(options, categories=(name,)), **run)
        index[name] = part
        write_json_atomic(folder / "categories.json", {
            "format": CATEGORY_MODELS_FORMAT,
            "categories": dict(sorted(index.items())),
        })
    return results


def _category_index(folder: Path) -> dict[str, str]:
    """The networks ``folder/categories.json`` already lists, kept when other categories train."""
    from vptoolkit.learn.checkpoint import read_json

    path = folder / "categories.json"
    if not path.exists():
        return {}
    entries = read_json(path, "per-category index")
    listed = entries.get("categories")
    if entries.get("format") != CATEGORY_MODELS_FORMAT or not isinstance(listed, dict) or not all(
            isinstance(key, str) and isinstance(value, str) for key, value in listed.items()):
        raise InputError(f"{path}: not a vptoolkit per-category index; move it away or train "
                         "into another folder")
    return dict(listed)


def _train_epoch(model: ViewpointNet, optimizer: torch.optim.Optimizer, train_data: Any,
                 n_train: int, *, phase: str, epoch: int, seed: int, batch_size: int,
                 workers: int, device: torch.device) -> float:
    train_data.set_epoch(epoch)
    batches = _batches(n_train, batch_size, _generator(seed, epoch, _SEED_SHUFFLE))
    model.train()
    model.set_generator(_generator(seed, epoch, _SEED_DROPOUT, device=device))
    loader = torch.utils.data.DataLoader(train_data, batch_sampler=batches, num_workers=workers,
                                         collate_fn=_collate)
    total = 0.0
    count = 0
    for batch in loader:
        batch = {key: value.to(device) if isinstance(value, torch.Tensor) else value
                 for key, value in batch.items()}
        outputs = model(batch["points"])
        loss = label_loss(phase, outputs, batch).mean()
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        total += float(loss.detach()) * len(batch["name"])
        count += len(batch["name"])
    return total / max(count, 1)
