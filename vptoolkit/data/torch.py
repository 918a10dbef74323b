"""A ``torch.utils.data.Dataset`` over a :class:`~vptoolkit.data.ViewpointDataset`.

Each item is one network input with the paper's augmentations (Schelling et
al. 2021, section "Data"):

1. ``n_points`` = 4096 input points: 1024 by farthest point sampling from a
   random start plus 3072 random others, chosen from the stored surface
   points (:func:`vptoolkit.points.network_input`);
2. a random rotation applied alike to the points and to every view
   direction, so the labels stay attached to the same parts of the model.

The paper draws three Euler angles uniformly from ``[0, 2 pi]``, which is not
uniform over rotations; here the rotation is uniform on SO(3) (a normalised
Gaussian quaternion), see :func:`random_rotation`.

Randomness
    Item randomness depends only on ``(seed, epoch, model name)``, never on
    the item's position, the worker process or the global random state: the
    generators are spawned from ``numpy.random.SeedSequence([seed, epoch,
    model_key(name)])``, the first for the rotation, the second for the
    point selection (so the points chosen do not depend on ``rotate``).
    Call :meth:`ViewpointTorchDataset.set_epoch` before each epoch (before
    iterating the DataLoader) for fresh augmentations. The epoch lives in
    shared memory, so worker processes see the new epoch too, also with
    ``persistent_workers=True``; a given epoch gives the same items in any
    process.

Indexing
    As PyTorch Geometric's datasets do, an integer gives an item, and a
    slice, a list, tuple, array or tensor of indices or a boolean mask
    (``inputs[0:80]``, ``inputs[[0, 2]]``) gives another
    :class:`ViewpointTorchDataset` over those models, with the same options
    and cache; its epoch starts at this one's and follows its own
    :meth:`~ViewpointTorchDataset.set_epoch`.

torch is imported when this module is imported; :mod:`vptoolkit.data` never
imports this module.
"""

from __future__ import annotations

import copy
import os
import warnings
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, overload

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import check_int
from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.dataset.store.schema import published_split
from vptoolkit.errors import InputError
from vptoolkit.optional import require
from vptoolkit.points import N_FPS_POINTS, N_NETWORK_POINTS
from vptoolkit.rotations import model_key, random_rotation

if TYPE_CHECKING:
    import torch
else:
    torch = require("torch", extra="torch")

__all__ = ["ViewpointTorchDataset"]


_SEED_POOL = 5

_NON_NEGATIVE = "a non-negative integer"


class ViewpointTorchDataset(torch.utils.data.Dataset[dict[str, Any]]):
    """Network inputs and labels from a :class:`~vptoolkit.data.ViewpointDataset`.

    Parameters
    ----------
    dataset : ViewpointDataset, path-like or str
        E.g. ``open_dataset(path)``, or one split of it; or, as a
        ``root``, the path or URL of a dataset or release, opened with
        :func:`~vptoolkit.data.open_dataset` (``ViewpointTorchDataset(
        "release/", split="train")``) and read for the adapter's life.
    split : str, optional
        Keep only the models of this split: ``"train"``, ``"validation"``
        (``"val"`` is an alias) or ``"test"`` (default: every model of
        ``dataset``). A category of ``dataset`` with no model in the split
        gets a ``UserWarning`` naming the category and the split.
    n_points : int
        Points per input (default: 4096).
    n_fps : int
        How many of them farthest point sampling picks (default: 1024).
    rotate : bool
        Apply a random rotation (default: True); when False the rotation is
        the identity and the points are the same as with True, unrotated.
    seed : int
        Base seed, non-negative (default: 0).
    fps_pool : int
        0 (default): run farthest point sampling for every item, from a
        start drawn per epoch. ``k > 0``: keep a pool of ``k`` farthest-point
        subsets per model, made once (subset ``j`` from a start drawn with
        ``SeedSequence([seed, 5, model_key(name), j])``), and give each item
        one of them, drawn per epoch; the random part and the rotation stay
        fresh every epoch. Farthest point sampling is most of the cost of an
        item, so a pool makes training several times faster while a model
        still shows ``k`` different structured subsets.
    point_features : sequence of str
        Features each input point carries after its coordinates, names of
        :data:`vptoolkit.point_features.POINT_FEATURES` (default: none), as a
        network whose ``ModelConfig.point_features`` names them reads them;
        made once per model from its stored mesh
        (:meth:`~vptoolkit.data.ViewpointDataset.point_features`); vector
        features (``"normal"``) are rotated with the points, numbers are not.
    cache : bool
        Keep every model's points, quality, best views and point features in
        memory after the first read (default: True; about 0.3 MB per model,
        0.08 MB more per point feature column).
    transform : callable, optional
        Called on every item dict (below) and returning the item the
        dataset gives, e.g. to add noise or drop keys; it runs in the
        worker process, after the augmentations. For randomness that
        follows the epoch, draw from :meth:`generators`.

    Notes
    -----
    An item is a dict:

    ==============  ======================  =============================================
    key             value                   meaning
    ==============  ======================  =============================================
    ``points``      (n_points, 3 + F)       input points, rotated, then their ``F``
                    float32                 point feature columns (vectors rotated)
    ``views``       (n_views, 3) float32    all view directions, rotated
    ``quality``     (n_views, K) float32    normalised quality per view, 1 = best
    ``best_views``  (K, 3) float32          best view per measure, rotated
    ``best_index``  (K,) int64              index of the best view per measure
    ``rotation``    (3, 3) float32          the rotation ``R``: rotated = ``v @ R.T``
    ``name``        str                     model name
    ``category``    str                     category
    ``label``       int                     class label, ``dataset.class_names[label]``
    ==============  ======================  =============================================

    ``K`` is the number of the store's measures (:attr:`measures`, by default
    the paper's four), in their order.

    Labels number the store's sorted category names (:attr:`class_names`,
    :attr:`num_classes` of them), the same in every split and subset.

    Points are rotated about the origin of the model coordinates; view
    directions are directions, so the pairing of views and surface holds
    for any centre. To score a prediction ``p`` made on the rotated input,
    rotate it back (``p @ R``) and look it up with
    :meth:`ViewpointDataset.quality_of`, or compare it with ``views``
    directly.
    """

    def __init__(self, dataset: ViewpointDataset | str | os.PathLike[str], *,
                 split: str | None = None,
                 n_points: int = N_NETWORK_POINTS, n_fps: int = N_FPS_POINTS, rotate: bool = True,
                 seed: int = 0, fps_pool: int = 0, point_features: Sequence[str] = (),
                 cache: bool = True,
                 transform: Callable[[dict[str, Any]], Any] | None = None) -> None:
        if isinstance(dataset, (str, os.PathLike)):
            dataset = open_dataset(dataset)
        if not isinstance(dataset, ViewpointDataset):
            raise InputError("dataset: expected a ViewpointDataset or the path or URL of one, "
                             f"got {type(dataset).__name__}")
        if split is not None:
            chosen = dataset.split(split)
            for category in sorted(set(dataset.categories) - set(chosen.categories)):
                warnings.warn(f"category {category!r} has no model in split "
                              f"{published_split(split)!r}", UserWarning, stacklevel=2)
            dataset = chosen
        self.dataset = dataset
        self.n_points = check_int(n_points, "n_points", minimum=0, expected=_NON_NEGATIVE)
        if self.n_points < 1:
            raise InputError("n_points: expected at least 1")
        self.n_fps = check_int(n_fps, "n_fps", minimum=0, expected=_NON_NEGATIVE)
        if self.n_fps > self.n_points:
            raise InputError(f"n_fps: {self.n_fps} exceeds n_points={self.n_points}")
        self.rotate = bool(rotate)
        self.seed = check_int(seed, "seed", minimum=0, expected=_NON_NEGATIVE)
        self.fps_pool = check_int(fps_pool, "fps_pool", minimum=0, expected=_NON_NEGATIVE)
        from vptoolkit.point_features import check_feature_names

        self.point_features = check_feature_names(point_features)
        self.cache = bool(cache)
        if transform is not None and not callable(transform):
            raise InputError(f"transform: expected a callable, got {type(transform).__name__}")
        self.transform = transform
        # In shared memory: DataLoader workers, persistent ones too, read the epoch set here.
        self._epoch = torch.zeros((), dtype=torch.int64).share_memory_()
        # Keyed by store row, so that the subsets indexing gives share them.
        self._items: dict[int, dict[str, Any]] = {}
        self._pool: dict[tuple[int, int], NDArray[np.int64]] = {}

    def __len__(self) -> int:
        return len(self.dataset)

    @property
    def measures(self) -> tuple[str, ...]:
        """The store's measure names, the columns of ``quality`` and the rows of
        ``best_views`` and ``best_index``."""
        return self.dataset.measures

    @property
    def class_names(self) -> list[str]:
        """Category of each label: the store's sorted category names, label ``i`` at ``[i]``."""
        return self.dataset.class_names

    @property
    def num_classes(self) -> int:
        """Number of classes, ``len(class_names)``, whichever models this dataset holds."""
        return len(self.dataset.class_names)

    @property
    def epoch(self) -> int:
        """The epoch whose augmentations items get (0 until :meth:`set_epoch`)."""
        return int(self._epoch.item())

    def set_epoch(self, epoch: int) -> None:
        """Select the augmentations of another epoch (non-negative), in every worker too."""
        self._epoch.fill_(check_int(epoch, "epoch", minimum=0, expected=_NON_NEGATIVE))

    def generators(self, index: int) -> tuple[np.random.Generator, np.random.Generator]:
        """The (rotation, point selection) generators of item ``index`` this epoch."""
        name = self.dataset.record(index)["name"]
        sequence = np.random.SeedSequence([self.seed, self.epoch, model_key(name)])
        rotation_seed, points_seed = sequence.spawn(2)
        return np.random.default_rng(rotation_seed), np.random.default_rng(points_seed)

    def _item(self, index: int) -> dict[str, Any]:
        row = self.dataset.row(index)
        if row in self._items:
            return self._items[row]
        item = self.dataset[index]
        kept = {key: item[key]
                for key in ("points", "quality", "best_index", "name", "category", "label",
                            "views")}
        if self.point_features:
            kept["features"] = self.dataset.point_features(index, self.point_features)
        if self.cache:
            self._items[row] = kept
        return kept

    def _fps_subset(self, index: int, member: int,
                    points: NDArray[np.float32]) -> NDArray[np.int64]:
        key = (self.dataset.row(index), member)
        if key not in self._pool:
            from vptoolkit.points import farthest_point_sampling

            name = self._item(index)["name"]
            rng = np.random.default_rng(
                np.random.SeedSequence([self.seed, _SEED_POOL, model_key(name), member]))
            self._pool[key] = farthest_point_sampling(points, self.n_fps, rng=rng)
        return self._pool[key]

    @overload
    def __getitem__(self, index: int | np.integer[Any]) -> dict[str, Any]: ...

    @overload
    def __getitem__(self, index: slice | Sequence[int] | NDArray[Any] | torch.Tensor
                    ) -> ViewpointTorchDataset: ...

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, torch.Tensor):
            index = index.tolist()  # a 0-d tensor gives an int
        if isinstance(index, (slice, list, tuple, np.ndarray)):
            return self._subset(index)
        from vptoolkit.points import network_input_indices

        item = self._item(index)
        rotation_rng, points_rng = self.generators(index)
        rotation = random_rotation(rotation_rng) if self.rotate else np.eye(3)
        fps = None
        if self.fps_pool and self.n_fps:
            member = int(points_rng.integers(self.fps_pool))
            fps = self._fps_subset(index, member, item["points"])
        chosen = network_input_indices(item["points"], self.n_points, self.n_fps, rng=points_rng,
                                       fps_indices=fps)
        points = item["points"][chosen]
        views = item["views"] @ rotation.T
        best_index = item["best_index"]
        turned = (points @ rotation.T).astype(np.float32)
        if self.point_features:
            from vptoolkit.point_features import turn_features

            features = turn_features(item["features"][chosen], self.point_features, rotation.T)
            turned = np.concatenate([turned, features.astype(np.float32, copy=False)], axis=1)
        result = {
            "points": torch.from_numpy(turned),
            "views": torch.from_numpy(views.astype(np.float32)),
            "quality": torch.from_numpy(np.array(item["quality"], dtype=np.float32)),
            "best_views": torch.from_numpy(views[best_index].astype(np.float32)),
            "best_index": torch.from_numpy(np.array(best_index, dtype=np.int64)),
            "rotation": torch.from_numpy(rotation.astype(np.float32)),
            "name": item["name"],
            "category": item["category"],
            "label": item["label"],
        }
        return result if self.transform is None else self.transform(result)

    def _subset(self, index: slice | Sequence[int] | NDArray[Any]) -> ViewpointTorchDataset:
        """The models ``index`` picks, with this dataset's options and caches; its epoch
        starts at this one's and follows its own :meth:`set_epoch`."""
        subset = copy.copy(self)
        subset.dataset = self.dataset[index]
        subset._epoch = torch.full((), self.epoch, dtype=torch.int64).share_memory_()
        return subset
