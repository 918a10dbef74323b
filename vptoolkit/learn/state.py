"""The resumable state of a training run: weights, Adam moments and history, without pickle.

A run writes ``<stem>.last.safetensors`` (the network's ``state_dict`` as
``model.*`` and every Adam tensor as ``optimizer.<index>.<key>``) and
``<stem>.last.json`` (``format``, the epoch, the run's arguments, Adam's
parameter groups, the history and the best score so far). The arguments are
the run's :class:`~vptoolkit.learn.options.TrainOptions` (``to_dict``) with
its paths and machine settings; :func:`load_state` refuses a state whose
options differ from the resumed run's in anything but ``epochs``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

from vptoolkit.checks import check_int, short_repr
from vptoolkit.errors import CheckpointError, InputError
from vptoolkit.files import write_json_atomic
from vptoolkit.learn.checkpoint import (
    checkpoint_paths,
    read_json,
    read_safetensors,
    write_safetensors_atomic,
)
from vptoolkit.learn.model import ViewpointNet
from vptoolkit.learn.options import TrainOptions
from vptoolkit.optional import require

if TYPE_CHECKING:
    import torch
    from torch import Tensor
else:
    torch = require("torch", extra="learn")
    Tensor = torch.Tensor

__all__ = ["TRAINING_STATE_FORMAT", "state_paths", "save_state", "load_state", "toolkit_version"]

TRAINING_STATE_FORMAT: Final = "vptoolkit-training-state"
"""``format`` entry of ``*.last.json``."""


def state_paths(output: str | os.PathLike[str]) -> tuple[Path, Path]:
    """The resumable-state files of a training output: ``<stem>.last.safetensors`` and ``.json``."""
    weights, _ = checkpoint_paths(output)
    stem = weights.with_suffix("")
    return stem.with_name(stem.name + ".last.safetensors"), stem.with_name(stem.name + ".last.json")


def _optimizer_tensors(
    optimizer: torch.optim.Optimizer,
) -> tuple[dict[str, Tensor], list[dict[str, Any]]]:
    state = optimizer.state_dict()
    tensors = {}
    for index, values in state["state"].items():
        for key, value in values.items():
            tensors[f"optimizer.{index}.{key}"] = torch.as_tensor(value)
    groups = []
    for group in state["param_groups"]:
        groups.append({key: (list(value) if isinstance(value, tuple) else value)
                       for key, value in group.items()})
    return tensors, groups


def _load_optimizer(optimizer: torch.optim.Optimizer, tensors: Mapping[str, Tensor],
                    groups: list[dict[str, Any]]) -> None:
    state: dict[int, dict[str, Tensor]] = {}
    for name, tensor in tensors.items():
        if name.startswith("optimizer."):
            _, index, key = name.split(".", 2)
            state.setdefault(int(index), {})[key] = tensor
    param_groups = []
    for group in groups:
        param_groups.append({key: (tuple(value) if key == "betas" else value)
                             for key, value in group.items()})
    optimizer.load_state_dict({"state": state, "param_groups": param_groups})


def toolkit_version() -> str:
    from vptoolkit._version import __version__

    return __version__


def save_state(model: ViewpointNet, optimizer: torch.optim.Optimizer, weights: Path,
               json_path: Path, *, arguments: Mapping[str, Any], epoch: int,
               history: list[dict[str, Any]], best: Mapping[str, Any]) -> None:
    tensors = {f"model.{name}": tensor for name, tensor in model.state_dict().items()}
    optimizer_tensors, groups = _optimizer_tensors(optimizer)
    tensors.update(optimizer_tensors)
    write_safetensors_atomic(weights, tensors, {"format": TRAINING_STATE_FORMAT})
    write_json_atomic(json_path, {
        "format": TRAINING_STATE_FORMAT,
        "format_version": 1,
        "epoch": epoch,
        "arguments": dict(arguments),
        "optimizer_param_groups": groups,
        "history": history,
        "best": {"epoch": best["epoch"], "score": best["score"], "scores": best["scores"]},
        "toolkit_version": toolkit_version(),
    })


def load_state(
    model: ViewpointNet, optimizer: torch.optim.Optimizer, weights: Path, json_path: Path,
    options: TrainOptions,
) -> tuple[int, list[dict[str, Any]], dict[str, Any]]:
    """Load a saved state into ``model`` and ``optimizer``; return (epoch, history, best).

    Raises
    ------
    InputError
        If the file is not a training state, its epoch is not that of its
        history or beyond ``options.epochs``, or its recorded options differ
        from ``options`` in anything but ``epochs`` (and a default ``lr_step``:
        :meth:`~vptoolkit.learn.options.TrainOptions.resume_conflicts`).
    CheckpointError
        If the weights or Adam state do not fit the network.
    """
    state = read_json(json_path, "training state")
    if state.get("format") != TRAINING_STATE_FORMAT:
        raise InputError(f"{json_path.name}: not a vptoolkit training state "
                         f"(format {state.get('format')!r})")
    history = state.get("history")
    if not isinstance(history, list):
        raise InputError(f"{json_path.name}: history: expected a list, got {short_repr(history)}")
    epoch = check_int(state.get("epoch"), f"{json_path.name}: epoch", minimum=0)
    if epoch != len(history):
        raise InputError(f"{json_path.name}: epoch {epoch} does not match the {len(history)} "
                         "epochs of its history")
    if epoch > options.epochs:
        raise InputError(f"{json_path.name}: the run is at epoch {epoch}, past the "
                         f"{options.epochs} epochs asked for")
    arguments = state.get("arguments")
    if not isinstance(arguments, Mapping):
        raise InputError(f"{json_path.name}: arguments: expected an object, "
                         f"got {short_repr(arguments)}")
    names = {item.name for item in fields(TrainOptions)}  # beside the run's paths and machine
    try:
        recorded = TrainOptions.from_dict({key: value for key, value in arguments.items()
                                           if key in names})
    except InputError as err:
        raise InputError(f"{json_path.name}: {err}") from err
    differing = options.resume_conflicts(recorded)
    if differing:
        details = ", ".join(f"{key}: {old!r} -> {new!r}" for key, (old, new) in differing.items())
        raise InputError(f"{json_path.name}: cannot resume with other options ({details})")
    tensors = read_safetensors(weights)
    model_state = {name[len("model."):]: tensor for name, tensor in tensors.items()
                   if name.startswith("model.")}
    try:
        model.load_state_dict(model_state, strict=True)
        _load_optimizer(optimizer, tensors, state["optimizer_param_groups"])
    except (RuntimeError, ValueError, KeyError) as err:
        raise CheckpointError(f"{weights.name}: training state does not match the network "
                              f"({err})") from err
    best = dict(state["best"])
    if best["score"] is None:
        best["score"] = -math.inf
    return epoch, list(history), best
