"""The training record a checkpoint's ``model.json`` carries.

What a trained network was made from and how: the dataset and its
attributes (with the measures it records), the models trained and validated
on, the arguments (the run's :class:`~vptoolkit.learn.options.TrainOptions`
as ``to_dict`` writes them, beside its paths and machine settings) and the
command, the epochs run, and the best epoch with its validation scores per
measure (:func:`training_record`); when a run ends, its whole per-epoch
history is added to the best checkpoint's configuration
(:func:`update_best_record`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from vptoolkit.data import ViewpointDataset
from vptoolkit.files import write_json_atomic
from vptoolkit.learn.checkpoint import read_json
from vptoolkit.learn.options import TrainOptions

__all__ = ["training_record", "update_best_record"]


def training_record(arguments: Mapping[str, Any], command: str | None, dataset: ViewpointDataset,
                     n_train: int, n_val: int, epochs: int,
                     epochs_completed: int, best: Mapping[str, Any]) -> dict[str, Any]:
    """The ``training`` entry of ``model.json``: data, arguments, command, epochs, best score.

    ``arguments`` are the run's options (:meth:`TrainOptions.to_dict`) with
    its ``dataset_path``, ``output`` and machine settings. ``command`` is the
    command line that started the run; without one, the equivalent
    :func:`~vptoolkit.learn.train.train_model` call is written (without the
    architecture, which ``model.json`` holds).
    """
    if command is None:
        names = {item.name for item in fields(TrainOptions)}
        options = ", ".join(f"{key}={value!r}" for key, value in arguments.items()
                            if key in names and key != "architecture")
        run = "".join(f", {key}={value!r}" for key, value in arguments.items()
                      if key not in names and key not in ("dataset_path", "output"))
        command = (f"vptoolkit.learn.train.train_model({arguments['dataset_path']!r}, "
                   f"{arguments['output']!r}, TrainOptions({options}){run})")
    return {
        "dataset": str(dataset.path),
        "dataset_attrs": {key: dataset.attrs.get(key)
                          for key in ("format", "schema_version", "n_models", "n_views",
                                      "measures", "toolkit_version", "created")},
        "n_train": n_train,
        "n_val": n_val,
        "arguments": dict(arguments),
        "command": command,
        "epochs": epochs,
        "epochs_completed": epochs_completed,
        "best_epoch": int(best["epoch"]),
        "best_score": float(best["score"]),
        "best_scores": dict(best["scores"]),
        "updated": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }


def update_best_record(config_path: Path, arguments: Mapping[str, Any], command: str | None,
                        dataset: ViewpointDataset, n_train: int, n_val: int,
                        epochs: int, history: list[dict[str, Any]],
                        best: Mapping[str, Any]) -> None:
    """Record the finished run's length and history in the best checkpoint's configuration."""
    config = read_json(config_path, "model configuration")
    config["training"] = training_record(arguments, command, dataset, n_train, n_val, epochs,
                                          len(history), best)
    config["training"]["history"] = history
    write_json_atomic(config_path, config)
