"""Checkpoint files: where a network's weights and configuration live, read and written safely.

A checkpoint is ``<stem>.safetensors`` (weights) beside ``<stem>.json`` (the
configuration); ``"default"`` and ``"points"`` name the networks bundled with
the package (:data:`BUNDLED_MODELS`). Every write is atomic and nothing is ever unpickled.
:func:`vptoolkit.learn.model.save_model` and ``load_model`` use these.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

from vptoolkit.errors import InputError
from vptoolkit.files import read_json_file, write_bytes_atomic
from vptoolkit.optional import require

if TYPE_CHECKING:
    from torch import Tensor

__all__ = [
    "MODEL_FORMAT",
    "DEFAULT_MODEL",
    "PRETRAINED",
    "BUNDLED_MODELS",
    "CLOUD_MODELS",
    "checkpoint_paths",
    "is_bundled_model",
    "read_json",
    "read_safetensors",
    "write_safetensors_atomic",
]

MODEL_FORMAT: Final = "vptoolkit-viewpoint-model"
"""``format`` entry of a checkpoint's JSON configuration."""

DEFAULT_MODEL: Final = "default"
"""Name that stands for the bundled pretrained checkpoint wherever a checkpoint path is taken."""

PRETRAINED: Final = Path(__file__).parent / "pretrained"
"""Folder of the bundled default checkpoint (``model.safetensors``, float16, and
``model.json`` with the command that trained it); see ``docs/results.md``."""

BUNDLED_MODELS: Final = {DEFAULT_MODEL: PRETRAINED, "points": PRETRAINED / "points"}
"""Names that stand for the bundled checkpoints wherever a checkpoint path is taken.

``"default"`` reads each point's face area (``ModelConfig.point_features``),
so it answers meshes and datasets; ``"points"`` reads coordinates alone, the
paper's input, and also answers bare point files."""

CLOUD_MODELS: Final = {DEFAULT_MODEL: "points"}
"""The bundled network that answers a point cloud in place of a bundled one that reads
what a cloud does not carry: ``"default"`` reads face areas, so a cloud gets
``"points"``, coordinates alone. Feeding ``"default"`` each point's spacing area
in place of its face area scores lower on VE and no higher on the other
measures (``docs/results.md``, "Bare point clouds: which network")."""


def is_bundled_model(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` stands for a bundled checkpoint: a string key of :data:`BUNDLED_MODELS`.

    A bundled network always wins over a file or folder of that name in the
    working directory, so the meaning of ``--model default`` does not depend
    on where the command runs; that file is reached as ``./default`` (or as
    a :class:`~pathlib.Path`, which always names a file).
    """
    return isinstance(path, str) and path in BUNDLED_MODELS


def checkpoint_paths(path: str | os.PathLike[str]) -> tuple[Path, Path]:
    """The weights and configuration files of a checkpoint.

    Parameters
    ----------
    path : path-like
        A folder (``model.safetensors`` and ``model.json`` inside it), a
        ``*.safetensors`` file or its ``*.json`` configuration, or the name
        of a checkpoint bundled with the package (:data:`BUNDLED_MODELS`, see
        :func:`is_bundled_model`).

    Returns
    -------
    weights, config : Path
        ``<stem>.safetensors`` and ``<stem>.json`` side by side.
    """
    if is_bundled_model(path):
        path = BUNDLED_MODELS[str(path)]
    path = Path(path)
    if path.suffix == ".safetensors":
        return path, path.with_suffix(".json")
    if path.suffix == ".json":
        return path.with_suffix(".safetensors"), path
    return path / "model.safetensors", path / "model.json"


def write_safetensors_atomic(path: Path, tensors: Mapping[str, Tensor],
                             metadata: Mapping[str, str] | None = None) -> None:
    """Write tensors as one safetensors file, atomically."""
    safetensors_torch = require("safetensors.torch", extra="learn")
    contiguous = {name: tensor.detach().contiguous().cpu() for name, tensor in tensors.items()}
    write_bytes_atomic(path, safetensors_torch.save(contiguous, metadata=dict(metadata or {})))


def read_json(path: Path, what: str) -> dict[str, Any]:
    """Read a JSON object, raising :class:`InputError` naming ``path``."""
    if not path.is_file():
        raise InputError(f"{path}: {what} not found")
    values = read_json_file(path)
    if not isinstance(values, dict):
        raise InputError(f"{path.name}: {what} is not a JSON object")
    return values


def read_safetensors(path: Path) -> dict[str, Tensor]:
    """Read every tensor of a safetensors file (no pickle involved)."""
    safetensors_torch = require("safetensors.torch", extra="learn")
    if not path.is_file():
        raise InputError(f"{path}: weights file not found")
    try:
        return dict(safetensors_torch.load_file(str(path), device="cpu"))
    except Exception as err:  # safetensors raises its own SafetensorError and OSError
        raise InputError(f"{path.name}: not a readable safetensors file ({err})") from err
