"""Validation during training, under the rotated protocol.

Each validation model is put under ``rotations`` fixed rotations seeded by
its name (:func:`vptoolkit.rotations.fixed_rotations`; none gives the stored
orientation), with the input points :func:`vptoolkit.learn.predict.predict`
would choose; a prediction scores the normalised quality of its nearest
sampled view (:func:`vptoolkit.learn.labels.nearest_view_quality`), in
[0, 1], higher is better, per measure the network learns (the dataset's
quality columns it was trained on).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from vptoolkit.data import ViewpointDataset
from vptoolkit.learn.draws import network_indices
from vptoolkit.learn.labels import nearest_view_quality
from vptoolkit.learn.model import ViewpointNet
from vptoolkit.optional import require
from vptoolkit.point_features import turn_features
from vptoolkit.rotations import fixed_rotations

if TYPE_CHECKING:
    import torch
    from torch import Tensor
else:
    torch = require("torch", extra="learn")
    Tensor = torch.Tensor

__all__ = ["validation_inputs", "validation_scores"]

_BATCH = 32  # validation inputs per forward pass


def validation_inputs(subset: ViewpointDataset, n_models: int, *, n_points: int, n_fps: int,
                      seed: int, rotations: int, device: torch.device,
                      columns: Sequence[int] | None = None,
                      point_features: Sequence[str] = ()) -> dict[str, Tensor]:
    """The validation inputs under the rotated protocol (as stored for ``rotations=0``).

    Returns ``points`` ``(n, n_points, 3 + F)`` (the coordinates, then the
    ``F`` columns of the named ``point_features``, vectors rotated with the
    points), ``views`` ``(n, V, 3)`` and
    ``quality`` ``(n, V, M)``: the stored normalised quality's ``columns``
    (default: all), one per measure of the network, in its order.
    """
    points, views, quality = [], [], []
    for index in range(n_models):
        item = subset[index]
        features = subset.point_features(index, point_features) if point_features else None
        chosen = network_indices(item["points"], n_points=n_points, n_fps=n_fps, seed=seed)[0]
        base = item["points"][chosen].astype(np.float32)
        turns = (fixed_rotations(item["name"], rotations, seed=seed) if rotations
                 else np.eye(3)[None])
        for rotation in turns:
            turned = base @ rotation.T
            points.append(turned if features is None else np.concatenate(
                [turned, turn_features(features[chosen], point_features, rotation.T)], axis=1))
            views.append(item["views"] @ rotation.T)
            quality.append(item["quality"] if columns is None
                           else item["quality"][:, list(columns)])
    return {key: torch.from_numpy(np.stack(values).astype(np.float32)).to(device)
            for key, values in (("points", points), ("views", views), ("quality", quality))}


def validation_scores(model: ViewpointNet, validation: Mapping[str, Tensor]) -> Tensor:
    """(M,) mean score per measure of ``model`` (put in eval mode) on :func:`validation_inputs`."""
    model.eval()
    scores = []
    with torch.inference_mode():
        for start in range(0, len(validation["points"]), _BATCH):
            part = slice(start, start + _BATCH)
            directions = model(validation["points"][part])["directions"]
            scores.append(nearest_view_quality(directions, validation["views"][part],
                                               validation["quality"][part]))
    return torch.cat(scores).mean(dim=0).cpu()
